#!/usr/bin/python3
"""Writes a TUM-layout sequence folder as a bag in the layout librealsense's recorder writes
(RealSense Viewer, rs-record): ROS 1, /device_0/sensor_<n>/<Stream>_<i>/... topics, depth in a
camera of its own (not registered to colour), the stream extrinsics on .../tf/0, Depth Units as
an option, a realsense_msgs/StreamInfo whose definition is only in the connection header, image
stamps on the device clock and record times from the start of the recording.

The depth camera is virtual: each depth pixel of the folder is back-projected with the colour
camera, moved into the depth camera (15 mm beside colour, turned 0.5 degrees) and projected
there, the nearest surface kept. Needs Debian's python3-rosbag, python3-sensor-msgs,
python3-geometry-msgs, python3-std-msgs, python3-diagnostic-msgs, python3-numpy, python3-opencv.

usage: write_realsense_bag.py FOLDER OUT.bag [--frames N] [--color-encoding rgb8|bgr8|yuyv]
       [--depth-units METRES] [--compression none|lz4|bz2] [--omit-extrinsics]
       [--depth-clock-offset SECONDS]
"""
import argparse
import hashlib
import math
import os
import sys

import cv2
import numpy as np
import rosbag
import yaml
from diagnostic_msgs.msg import KeyValue
from geometry_msgs.msg import Transform
from rospy import Time
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Float32, String, UInt32

DEPTH_SIZE = (640, 480)
DEPTH_K = (420.0, 420.0, 318.5, 242.5)  # fx fy cx cy of the virtual depth camera [px]
BASELINE_M = 0.015
TURN_RAD = math.radians(0.5)


class StreamInfo:
    """realsense_msgs/StreamInfo: no Python package holds it, as in a real recording."""
    _type = "realsense_msgs/StreamInfo"
    _full_text = "uint32 fps\nstring encoding\nbool is_recommended\n"
    _md5sum = hashlib.md5(b"uint32 fps\nstring encoding\nbool is_recommended").hexdigest()

    @staticmethod
    def serialize(fps, encoding):
        data = encoding.encode()
        return (np.uint32(fps).tobytes() + np.uint32(len(data)).tobytes() + data + b"\x01")


def read_list(folder, name):
    entries = []
    with open(os.path.join(folder, name)) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                stamp, path = line.split()[:2]
                entries.append((float(stamp), os.path.join(folder, path)))
    return entries


def depth_from_color():
    """The depth camera's pose as librealsense stores it: p_depth = R p_color + t."""
    c, s = math.cos(TURN_RAD), math.sin(TURN_RAD)
    rotation = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return rotation, np.array([-BASELINE_M, 0.0, 0.0])


def quaternion(rotation):
    w = math.sqrt(max(0.0, 1.0 + np.trace(rotation))) / 2.0
    return ((rotation[2, 1] - rotation[1, 2]) / (4 * w), (rotation[0, 2] - rotation[2, 0]) / (4 * w),
            (rotation[1, 0] - rotation[0, 1]) / (4 * w), w)


def transform_msg(rotation, translation):
    msg = Transform()
    msg.translation.x, msg.translation.y, msg.translation.z = translation
    (msg.rotation.x, msg.rotation.y, msg.rotation.z, msg.rotation.w) = quaternion(rotation)
    return msg


def camera_info(stamp, size, k, model, d):
    msg = CameraInfo()
    msg.header.stamp = stamp
    msg.width, msg.height = size
    fx, fy, cx, cy = k
    msg.K = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
    msg.P = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    msg.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    msg.distortion_model = model
    msg.D = list(d)
    return msg


def color_rays(camera):
    """x/z and y/z of each colour pixel, the colour camera's distortion undone."""
    k = np.array([[camera["fx"], 0, camera["cx"]], [0, camera["fy"], camera["cy"]], [0, 0, 1]])
    u, v = np.meshgrid(np.arange(camera["width"]), np.arange(camera["height"]))
    pixels = np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64)[:, None, :]
    rays = cv2.undistortPoints(pixels, k, np.array(camera.get("distortion", [0.0] * 5)))
    return rays[:, 0, 0].reshape(u.shape), rays[:, 0, 1].reshape(u.shape)


def warp_depth(depth_m, rays, rotation, translation):
    """The folder's depth (in the colour camera) as the virtual depth camera sees it [m]."""
    v, u = np.nonzero(depth_m > 0)
    z = depth_m[v, u]
    points = np.stack([rays[0][v, u] * z, rays[1][v, u] * z, z])
    moved = rotation @ points + translation[:, None]
    dfx, dfy, dcx, dcy = DEPTH_K
    keep = moved[2] > 0.05
    moved = moved[:, keep]
    du = np.rint(dfx * moved[0] / moved[2] + dcx).astype(np.int64)
    dv = np.rint(dfy * moved[1] / moved[2] + dcy).astype(np.int64)
    inside = (du >= 0) & (du < DEPTH_SIZE[0]) & (dv >= 0) & (dv < DEPTH_SIZE[1])
    cell = dv[inside] * DEPTH_SIZE[0] + du[inside]
    depth = moved[2][inside]
    order = np.lexsort((depth, cell))  # by cell, nearest first
    first = np.unique(cell[order], return_index=True)[1]
    out = np.zeros(DEPTH_SIZE[0] * DEPTH_SIZE[1])
    out[cell[order][first]] = depth[order][first]
    return out.reshape(DEPTH_SIZE[1], DEPTH_SIZE[0])


def yuyv(bgr):
    """YUYV 4:2:2 in BT.601 video range, as cameras write it."""
    b, g, r = (bgr[:, :, i].astype(np.float64) for i in range(3))
    y = 16 + 0.257 * r + 0.504 * g + 0.098 * b
    u = 128 - 0.148 * r - 0.291 * g + 0.439 * b
    v = 128 + 0.439 * r - 0.368 * g - 0.071 * b
    out = np.empty((bgr.shape[0], bgr.shape[1] * 2), np.uint8)
    out[:, 0::2] = np.clip(np.rint(y), 0, 255)
    out[:, 1::4] = np.clip(np.rint((u[:, 0::2] + u[:, 1::2]) / 2), 0, 255)
    out[:, 3::4] = np.clip(np.rint((v[:, 0::2] + v[:, 1::2]) / 2), 0, 255)
    return out


def image_msg(stamp, array, encoding, frame_number):
    msg = Image()
    msg.header.stamp = stamp
    msg.header.seq = frame_number
    msg.height, msg.width = array.shape[0], array.shape[1]
    if encoding == "yuyv":
        msg.width //= 2
    msg.encoding = encoding
    msg.step = array.shape[1] * (array.itemsize if array.ndim == 2 else 3)
    msg.data = array.tobytes()
    return msg


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("out")
    parser.add_argument("--frames", type=int, default=0, help="colour frames to write (0: all)")
    parser.add_argument("--color-encoding", default="rgb8", choices=["rgb8", "bgr8", "yuyv"])
    parser.add_argument("--depth-units", type=float, default=0.0002, help="metres per unit")
    parser.add_argument("--compression", default="none", choices=["none", "lz4", "bz2"])
    parser.add_argument("--omit-extrinsics", action="store_true", help="write no .../tf/0")
    parser.add_argument("--depth-clock-offset", type=float, default=0.0,
                        help="added to the depth images' header stamps [s]")
    args = parser.parse_args()

    with open(os.path.join(args.folder, "camera.yaml")) as f:
        camera = yaml.safe_load(f)
    color_k = (camera["fx"], camera["fy"], camera["cx"], camera["cy"])
    color_d = camera.get("distortion", [0.0] * 5)
    colors = read_list(args.folder, "rgb.txt")
    depths = read_list(args.folder, "depth.txt")
    if args.frames > 0:
        colors = colors[:args.frames]
        depths = [d for d in depths if d[0] <= colors[-1][0] + 0.02]
    start = min(colors[0][0], depths[0][0])
    rotation, translation = depth_from_color()
    rays = color_rays(camera)

    def record_time(stamp):
        return Time.from_sec(stamp - start + 1e-3)  # the recorder's clock starts with the file

    depth_prefix = "/device_0/sensor_0/Depth_0"
    color_prefix = "/device_0/sensor_1/Color_0"
    with rosbag.Bag(args.out, "w", compression=args.compression) as bag:
        t0 = Time.from_sec(1e-6)
        bag.write("/file_version", UInt32(data=3), t0)
        for key, value in (("Name", "Intel RealSense D435"), ("Serial Number", "000000000001"),
                           ("Firmware Version", "5.13.0.50"), ("Product Line", "D400")):
            bag.write("/device_0/info", KeyValue(key=key, value=value), t0)
        bag.write("/device_0/sensor_0/info", KeyValue(key="Name", value="Stereo Module"), t0)
        bag.write("/device_0/sensor_1/info", KeyValue(key="Name", value="RGB Camera"), t0)
        units = "/device_0/sensor_0/option/Depth Units"
        bag.write(units + "/value", Float32(data=args.depth_units), t0)
        bag.write(units + "/description", String(data="Number of meters represented by a single "
                                                 "depth unit"), t0)
        for prefix, encoding in ((depth_prefix, "mono16"), (color_prefix, args.color_encoding)):
            bag.write(prefix + "/info", (StreamInfo._type, StreamInfo.serialize(30, encoding),
                                         StreamInfo._md5sum, StreamInfo), t0, raw=True)
        # The reference of the extrinsic group is the depth stream (librealsense's pin stream).
        if not args.omit_extrinsics:
            bag.write(depth_prefix + "/tf/0", transform_msg(np.eye(3), np.zeros(3)), t0)
            color_from_depth = rotation.T, -rotation.T @ translation
            bag.write(color_prefix + "/tf/0", transform_msg(*color_from_depth), t0)
        bag.write(depth_prefix + "/info/camera_info",
                  camera_info(t0, DEPTH_SIZE, DEPTH_K, "Brown Conrady", [0.0] * 5), t0)
        bag.write(color_prefix + "/info/camera_info",
                  camera_info(t0, (camera["width"], camera["height"]), color_k,
                              "Inverse Brown Conrady" if not any(color_d) else "Brown Conrady",
                              color_d), t0)

        events = [(s, "color", p) for s, p in colors] + [(s, "depth", p) for s, p in depths]
        events.sort()
        for number, (stamp, kind, path) in enumerate(events):
            device_stamp = Time.from_sec(stamp)
            if kind == "color":
                bgr = cv2.imread(path, cv2.IMREAD_COLOR)
                array = {"rgb8": lambda: cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), "bgr8": lambda: bgr,
                         "yuyv": lambda: yuyv(bgr)}[args.color_encoding]()
                msg = image_msg(device_stamp, array, args.color_encoding, number)
                bag.write(color_prefix + "/image/data", msg, record_time(stamp))
            else:
                raw = cv2.imread(path, cv2.IMREAD_UNCHANGED)
                depth_m = warp_depth(raw.astype(np.float64) / camera["depth_factor"], rays,
                                     rotation, translation)
                units_array = np.clip(np.rint(depth_m / args.depth_units), 0, 65535).astype(np.uint16)
                device_stamp = Time.from_sec(stamp + args.depth_clock_offset)
                msg = image_msg(device_stamp, units_array, "mono16", number)
                bag.write(depth_prefix + "/image/data", msg, record_time(stamp))
                bag.write(depth_prefix + "/image/metadata",
                          KeyValue(key="Frame Counter", value=str(number)), record_time(stamp))
    return 0


if __name__ == "__main__":
    sys.exit(main())
