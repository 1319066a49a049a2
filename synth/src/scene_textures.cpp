// Procedural textures: features for ORB the way real rooms give them.
#include "scene_textures.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace stillmap::synth {

cv::Mat NoiseTexture(cv::RNG& rng, const cv::Scalar& base, double amplitude, int size, int cells,
                     double grain) {
  cv::Mat coarse(cells, cells, CV_32FC3);
  rng.fill(coarse, cv::RNG::NORMAL, 0.0, amplitude);
  cv::Mat smooth;
  cv::resize(coarse, smooth, cv::Size(size, size), 0, 0, cv::INTER_CUBIC);
  cv::Mat fine(size, size, CV_32FC3);
  rng.fill(fine, cv::RNG::NORMAL, 0.0, grain);
  cv::Mat texture = smooth + fine + base;
  texture.convertTo(texture, CV_8UC3);
  return texture;
}

cv::Scalar RandomColor(cv::RNG& rng, int lo, int hi) {
  return cv::Scalar(rng.uniform(lo, hi), rng.uniform(lo, hi), rng.uniform(lo, hi));
}

cv::Mat WallTexture(cv::RNG& rng, const cv::Scalar& paint) {
  cv::Mat wall = NoiseTexture(rng, paint, 6.0, 1024, 12, 3.0);
  const int posters = rng.uniform(5, 9);
  for (int p = 0; p < posters; ++p) {
    const int w = rng.uniform(90, 220), h = rng.uniform(90, 260);
    const int x = rng.uniform(10, 1024 - w - 10), y = rng.uniform(40, 700 - h);
    const cv::Rect rect(x, y, w, h);
    cv::rectangle(wall, rect, RandomColor(rng, 20, 235), cv::FILLED);
    for (int s = 0; s < 12; ++s) {
      const cv::Point a(x + rng.uniform(0, w), y + rng.uniform(0, h));
      const cv::Scalar color = RandomColor(rng, 0, 255);
      switch (rng.uniform(0, 3)) {
        case 0:
          cv::circle(wall, a, rng.uniform(5, 30), color, cv::FILLED);
          break;
        case 1:
          cv::rectangle(wall, a, cv::Point(a.x + rng.uniform(8, 40), a.y + rng.uniform(8, 40)),
                        color, cv::FILLED);
          break;
        default:
          cv::putText(wall, "STILL", a, cv::FONT_HERSHEY_DUPLEX, 0.6 + rng.uniform(0.0, 1.0), color,
                      2);
      }
    }
    cv::rectangle(wall, rect, cv::Scalar(20, 20, 20), 4);
  }
  cv::rectangle(wall, cv::Rect(0, 985, 1024, 39), cv::Scalar(60, 70, 80), cv::FILLED);  // skirting
  return wall;
}

cv::Mat WoodTexture(cv::RNG& rng, const cv::Scalar& tone) {
  cv::Mat wood(256, 256, CV_8UC3);
  const double frequency = rng.uniform(0.15, 0.3);
  cv::Mat warp = NoiseTexture(rng, cv::Scalar::all(0), 40.0, 256, 6, 0.0);
  for (int y = 0; y < 256; ++y) {
    for (int x = 0; x < 256; ++x) {
      const double grain =
          0.5 + 0.5 * std::sin(frequency * (y + 0.3 * warp.at<cv::Vec3b>(y, x)[0]));
      for (int c = 0; c < 3; ++c) {
        wood.at<cv::Vec3b>(y, x)[c] =
            cv::saturate_cast<uchar>(tone[c] * (0.7 + 0.45 * grain) + rng.gaussian(4.0));
      }
    }
  }
  return wood;
}

cv::Mat StripeTexture(cv::RNG& rng, const cv::Scalar& a, const cv::Scalar& b) {
  cv::Mat cloth = NoiseTexture(rng, a, 5.0, 128, 8, 6.0);
  const int period = rng.uniform(10, 26);
  for (int y = 0; y < 128; y += period) {
    cv::rectangle(cloth, cv::Rect(0, y, 128, period / 2), b, cv::FILLED);
  }
  cv::Mat grain(128, 128, CV_8UC3);
  rng.fill(grain, cv::RNG::UNIFORM, 0, 12);
  return cloth + grain;
}

cv::Mat ScreenTexture(cv::RNG& rng) {
  cv::Mat screen(256, 384, CV_8UC3, cv::Scalar(40, 30, 25));
  for (int w = 0; w < 6; ++w) {
    const cv::Rect window(rng.uniform(0, 300), rng.uniform(0, 190), rng.uniform(60, 160),
                          rng.uniform(40, 120));
    cv::rectangle(screen, window, RandomColor(rng, 60, 250), cv::FILLED);
    cv::rectangle(screen, window, cv::Scalar(10, 10, 10), 3);
    for (int line = window.y + 14; line < window.y + window.height - 6; line += 12) {
      cv::line(screen, {window.x + 8, line}, {window.x + rng.uniform(20, 150), line},
               cv::Scalar(15, 15, 15), 2);
    }
  }
  return screen;
}

// Hair on top and at the back, eyes, brows and a mouth at the front (u near 0 and 1).
cv::Mat FaceTexture(cv::RNG& rng, const cv::Scalar& skin, const cv::Scalar& hair) {
  cv::Mat face = NoiseTexture(rng, skin, 6.0, 128, 6, 3.0);
  cv::rectangle(face, cv::Rect(0, 0, 128, 40), hair, cv::FILLED);  // top
  cv::rectangle(face, cv::Rect(30, 0, 68, 80), hair, cv::FILLED);  // back of the head
  for (int side : {-1, 1}) {
    const int u = side < 0 ? 121 : 7;  // +-0.055 of a turn from the front
    cv::ellipse(face, {u, 58}, {4, 3}, 0, 0, 360, cv::Scalar(245, 245, 245), cv::FILLED);
    cv::circle(face, {u, 58}, 2, cv::Scalar(40, 30, 20), cv::FILLED);
    cv::line(face, {u - 5, 51}, {u + 5, 51}, hair, 2);
  }
  cv::line(face, {0, 82}, {6, 82}, cv::Scalar(60, 60, 150), 2);  // mouth, across the seam
  cv::line(face, {122, 82}, {127, 82}, cv::Scalar(60, 60, 150), 2);
  return face;
}

cv::Mat TileTexture(cv::RNG& rng, const cv::Scalar& base, int tiles, int size) {
  cv::Mat floor = NoiseTexture(rng, base, 4.0, size, 24, 9.0);
  const int tile = size / tiles;
  for (int ty = 0; ty < tiles; ++ty) {
    for (int tx = 0; tx < tiles; ++tx) {
      const cv::Rect rect(tx * tile, ty * tile, tile, tile);
      floor(rect) += cv::Scalar::all(rng.uniform(-14, 14));
    }
  }
  for (int s = 0; s < tiles * tiles; ++s) {  // scuffs and specks, about one per tile
    const cv::Point at(rng.uniform(0, size), rng.uniform(0, size));
    const cv::Size half(rng.uniform(2, 14), rng.uniform(1, 6));
    cv::ellipse(floor, at, half, rng.uniform(0, 180), 0, 360, base * rng.uniform(0.45, 0.8),
                cv::FILLED);
  }
  for (int g = 0; g <= tiles; ++g) {  // grout
    const int at = std::min(g * tile, size - 1);
    cv::line(floor, {at, 0}, {at, size - 1}, base * 0.55, 3);
    cv::line(floor, {0, at}, {size - 1, at}, base * 0.55, 3);
  }
  return floor;
}

cv::Mat PlainPaint(cv::RNG& rng, const cv::Scalar& paint) {
  return NoiseTexture(rng, paint, 2.5, 256, 6, 1.0);
}

cv::Mat WhiteboardTexture(cv::RNG& rng) {
  cv::Mat board = NoiseTexture(rng, cv::Scalar(238, 240, 240), 2.0, 512, 4, 1.5);
  for (int s = 0; s < 14; ++s) {
    const cv::Scalar marker = std::vector<cv::Scalar>{
        {30, 30, 30}, {160, 40, 30}, {30, 30, 170}, {40, 120, 30}}[rng.uniform(0, 4)];
    const cv::Point a(rng.uniform(20, 480), rng.uniform(20, 480));
    switch (rng.uniform(0, 3)) {
      case 0:
        cv::rectangle(board, a, a + cv::Point(rng.uniform(30, 120), rng.uniform(20, 80)), marker,
                      3);
        break;
      case 1:
        cv::line(board, a, cv::Point(rng.uniform(20, 480), rng.uniform(20, 480)), marker, 3);
        break;
      default:
        cv::putText(board, "plan", a, cv::FONT_HERSHEY_SIMPLEX, 0.8 + rng.uniform(0.0, 0.8), marker,
                    2);
    }
  }
  cv::rectangle(board, cv::Rect(0, 0, 512, 512), cv::Scalar(90, 90, 95), 10);  // frame
  return board;
}

}  // namespace stillmap::synth
