// Hostile input, round 3 (the rest of hostile_user_data_test.cpp): input that used to pass in
// silence: class names that do not fit the model, swapped or damaged models, a near-empty map, an
// implausible depth scale, a frozen colour stream, an output folder that is the sequence through a
// bind mount, a vertical grid.floor, seeds that wrap; and the messages of round 3.
#include "hostile_user_data.h"

namespace stillmap {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;
using testing::WriteText;

// ---- input that used to pass in silence -----------------------------------------------------

// Names files that do not fit the model, and models swapped, cut short, damaged or not models at
// all: exit 2 at load, naming the file, before anything is written.
TEST(HostileUserDataTest, ModelsAndNamesThatDoNotFitAreNamedAtLoad) {
  const std::optional<std::string> yolox = testing::SharedModels("yolox_nano");
  const std::optional<std::string> deeplab = testing::SharedModels("deeplabv3_mnv2_voc");
  const std::optional<std::string> fastest = testing::SharedModels("yolo_fastest_1.1");
  if (!yolox || !deeplab || !fastest) GTEST_SKIP() << "no detector models in ../shared/models";
  // Per detector: its folder, names file and model file (Yolo-Fastest's weights).
  struct Model {
    std::string detector, folder, names, file;
  };
  const std::vector<Model> kinds = {
      {"yolox", "yolox_nano", "coco.names", "yolox_nano.onnx"},
      {"deeplab", "deeplabv3_mnv2_voc", "voc.names", "deeplab_v3_mnv2_voc_opencv46.onnx"},
      {"yolo-fastest", "yolo_fastest_1.1", "coco.names", "yolo-fastest-1.1.weights"}};
  Generator g(36);
  for (size_t i = 0; i < kInstances * 3; ++i) {
    Case c;
    const std::string models = c.dir / "models";
    fs::create_directories(models);
    for (const Model& each : kinds) {
      fs::copy(*yolox + "/" + each.folder, models + "/" + each.folder, fs::copy_options::recursive);
    }
    const Model& chosen = kinds[g.Below(kinds.size())];
    const Model& another = kinds[chosen.detector == "yolox" ? 1 : 0];
    const std::string folder = models + "/" + chosen.folder + "/";
    const std::string names = folder + chosen.names;
    const std::string model = folder + chosen.file;
    const std::string other = models + "/" + another.folder + "/" + another.file;
    const size_t kind = g.Below(7);
    std::string wrong = names;
    if (kind == 0) {
      WriteText(names, "");
    } else if (kind == 1) {
      std::vector<std::string> lines = Lines(ReadText(names));
      lines.resize(g.Below(lines.size()));
      WriteText(names, Join(lines));
    } else if (kind == 2) {
      WriteText(names, RandomBytes(g, 200));
    } else if (kind == 3) {
      fs::copy_file(other, model, fs::copy_options::overwrite_existing);
      wrong = model;
    } else if (kind == 4) {
      fs::resize_file(model, fs::file_size(model) * g.Below(100) / 100);
      wrong = model;
    } else if (kind == 5) {
      std::string bytes = ReadText(model);
      for (size_t k = 0; k < 64; ++k) bytes[g.Below(bytes.size() / 8)] ^= 0x5a;
      WriteText(model, bytes);
      wrong = model;
    } else {
      WriteText(model, "not a model\n");
      wrong = model;
    }
    std::string output;
    const int status = c.Build("--detector " + chosen.detector + " --models " + models, &output);
    EXPECT_EQ(status, 2) << "kind " << kind << "\n" << output;
    EXPECT_NE(output.find(wrong), std::string::npos) << "kind " << kind << "\n" << output;
    EXPECT_FALSE(fs::exists(c.out + "/map.ply"));
  }
}

// A near-empty map fails; a depth scale far off and a frozen colour stream are warned of (and
// the base sequence itself raises neither warning).
TEST(HostileUserDataTest, ImplausibleRecordingsAreNamed) {
  Generator g(37);
  for (size_t i = 0; i < kInstances * 2; ++i) {
    Case c;
    std::string output;
    const size_t kind = g.Below(3);
    const std::vector<std::string> depths = FilesIn(c.sequence + "/depth");
    if (kind == 0) {
      for (const std::string& path : depths) {
        cv::Mat depth = cv::imread(path, cv::IMREAD_UNCHANGED);
        cv::Mat kept = cv::Mat::zeros(depth.size(), depth.type());
        for (size_t k = 0, n = 1 + g.Below(3); k < n; ++k) {
          const int r = static_cast<int>(g.Below(depth.rows)),
                    col = static_cast<int>(g.Below(depth.cols));
          kept.at<std::uint16_t>(r, col) = 10000;
        }
        cv::imwrite(path, kept);
      }
      EXPECT_EQ(c.Build("", &output), 1) << output;
      EXPECT_NE(output.find("empty"), std::string::npos) << output;
    } else if (kind == 1) {
      const double factor = g.Pick(std::vector<double>{5.0, 0.2, 8.0, 0.125});
      std::string camera = ReadText(c.sequence + "/camera.yaml");
      camera = std::regex_replace(camera, std::regex("depth_factor: .*"),
                                  "depth_factor: " + std::to_string(5000.0 * factor));
      WriteText(c.sequence + "/camera.yaml", camera);
      const int status = c.Build("", &output);
      EXPECT_TRUE(status == 0 || status == 1) << output;
      EXPECT_NE(output.find("depth scale"), std::string::npos) << factor << "\n" << output;
    } else {
      const cv::Mat noise(120, 160, CV_8UC3);
      cv::randu(noise, 0, 255);
      for (const std::string& path : FilesIn(c.sequence + "/rgb")) cv::imwrite(path, noise);
      EXPECT_EQ(c.Build("", &output), 0) << output;
      EXPECT_NE(output.find("frozen"), std::string::npos) << output;
    }
  }
  Case c(true);
  std::string output;
  ASSERT_EQ(c.Run("build " + c.sequence + " -o " + c.out + " --quiet", &output), 0) << output;
  EXPECT_EQ(output.find("frozen"), std::string::npos) << output;
  EXPECT_EQ(output.find("depth scale"), std::string::npos) << output;
}

// An output folder that is the sequence (or inside it) through a bind mount is refused.
TEST(HostileUserDataTest, AnOutputFolderMountedOverTheSequenceIsRefused) {
  Generator g(38);
  for (size_t i = 0; i < kInstances; ++i) {
    Case c;
    const std::string mount = c.dir / RandomName(g, "");
    fs::create_directories(mount);
    if (::mount(c.sequence.c_str(), mount.c_str(), nullptr, MS_BIND, nullptr) != 0) {
      GTEST_SKIP() << "bind mounts need privileges this machine does not give";
    }
    const std::string out = g.Below(2) == 0 ? mount : mount + "/" + RandomName(g, "");
    const size_t before = std::distance(fs::directory_iterator(c.sequence), {});
    std::string output;
    const int status = c.Run("build " + c.sequence + " -o " + out + " --quiet", &output);
    ::umount(mount.c_str());
    EXPECT_EQ(status, 2) << output;
    EXPECT_NE(output.find("sequence folder"), std::string::npos) << output;
    EXPECT_EQ(std::distance(fs::directory_iterator(c.sequence), {}), before);
  }
}

// Values that wrap or make no sense: a vertical grid.floor, negative or overflowing seeds.
TEST(HostileUserDataTest, ValuesThatWrapOrMakeNoSenseAreRefused) {
  Generator g(39);
  for (size_t i = 0; i < kInstances * 2; ++i) {
    Case c;
    std::string output;
    const double angle = static_cast<double>(g.Below(360)) * M_PI / 180.0;
    const std::string floor = std::to_string(std::cos(angle)) + " 0 " +
                              std::to_string(std::sin(angle)) + " " +
                              std::to_string(static_cast<double>(g.Below(5)) - 2.0);
    EXPECT_EQ(c.Build("--set 'grid.floor=" + floor + "'", &output), 2) << floor << "\n" << output;
    EXPECT_NE(output.find("not a floor"), std::string::npos) << output;
    const std::string seed = g.Pick(
        std::vector<std::string>{"-" + std::to_string(1 + g.Below(1000)), "18446744073709551616",
                                 "99999999999999999999999", "12x", "1e3", "-0"});
    EXPECT_EQ(
        c.Run("synth " + (c.dir / "s") + " --scenario static --frames 2 --seed " + seed, &output),
        2)
        << seed << "\n"
        << output;
    EXPECT_FALSE(fs::exists(c.dir / "s"));
  }
}

// ---- messages ------------------------------------------------------------------------------

TEST(HostileUserDataTest, DamagedFilesGetOurSentence) {
  Generator g(40);
  for (size_t i = 0; i < kInstances * 3; ++i) {
    const size_t kind = g.Below(5);
    const Case c(kind == 4);
    std::string output;
    if (kind == 0) {  // a PLY header declaring more vertices than its bytes hold
      ASSERT_EQ(c.Build("", &output), 0) << output;
      const unsigned long long vertices = 1000000000ULL * (1 + g.Below(1000000));
      WriteText(c.out + "/map.ply", "ply\nformat binary_little_endian 1.0\nelement vertex " +
                                        std::to_string(vertices) +
                                        "\nproperty float x\nproperty float y\nproperty float "
                                        "z\nend_header\n" +
                                        RandomBytes(g, 64));
      EXPECT_EQ(c.Run("view " + c.out + " --png", &output), 2) << output;
      EXPECT_NE(output.find("declares"), std::string::npos) << output;
    } else if (kind == 1) {  // NUL or binary bytes in rgb.txt
      std::string list = ReadText(c.sequence + "/rgb.txt");
      const size_t at = list.find("rgb/") + 4;
      if (g.Below(2) == 0) {
        list.insert(at, 1, '\0');
      } else {
        list = RandomBytes(g, 400);
      }
      WriteText(c.sequence + "/rgb.txt", list);
      EXPECT_EQ(c.Build("", &output), 2) << output;
      for (const char byte : output) {
        const auto u = static_cast<unsigned char>(byte);
        EXPECT_TRUE(u >= 0x20 || byte == '\n') << "raw byte " << static_cast<int>(u);
        if (u < 0x20 && byte != '\n') break;
      }
    } else if (kind == 2) {  // CR-only line endings: read as lines
      for (const char* list : {"rgb.txt", "depth.txt", "groundtruth.txt"}) {
        std::string text = ReadText(c.sequence + "/" + list);
        std::replace(text.begin(), text.end(), '\n', '\r');
        WriteText(c.sequence + "/" + list, text);
      }
      EXPECT_EQ(c.Build("", &output), 0) << output;
    } else if (kind == 3) {  // a broken CRC in a PNG: our sentence, not libpng's
      const std::string folder = g.Below(2) == 0 ? "/rgb" : "/depth";
      const std::vector<std::string> paths = FilesIn(c.sequence + folder);
      const std::string path = paths[g.Below(paths.size())];
      std::string bytes = ReadText(path);
      const size_t idat = bytes.find("IDAT");
      ASSERT_NE(idat, std::string::npos);
      const size_t length = (static_cast<unsigned char>(bytes[idat - 2]) << 8) +
                            static_cast<unsigned char>(bytes[idat - 1]);
      bytes[idat + 4 + length + g.Below(4)] ^= static_cast<char>(1 + g.Below(255));
      WriteText(path, bytes);
      EXPECT_EQ(c.Build("", &output), 2) << output;
      EXPECT_NE(output.find(path), std::string::npos) << output;
    } else {  // an empty ground truth: a tracked build maps without ATE, --poses groundtruth stops
      WriteText(c.sequence + "/groundtruth.txt", g.Below(2) == 0 ? "" : "# no poses\n\n");
      EXPECT_EQ(c.Run("build " + c.sequence + " -o " + c.out + " --quiet", &output), 0) << output;
      EXPECT_NE(output.find("holds no poses"), std::string::npos) << output;
      EXPECT_EQ(c.Build("", &output), 2) << output;
    }
  }
}

// Writes `bgr` as an Adobe-style CMYK JPEG (inverted channels, APP14 marker) through libjpeg.
void WriteCmykJpeg(const std::string& path, const cv::Mat& bgr) {
  jpeg_compress_struct info{};
  jpeg_error_mgr error{};
  info.err = jpeg_std_error(&error);
  jpeg_create_compress(&info);
  FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  jpeg_stdio_dest(&info, file);
  info.image_width = static_cast<JDIMENSION>(bgr.cols);
  info.image_height = static_cast<JDIMENSION>(bgr.rows);
  info.input_components = 4;
  info.in_color_space = JCS_CMYK;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, 95, TRUE);
  jpeg_start_compress(&info, TRUE);
  std::vector<unsigned char> row(static_cast<size_t>(bgr.cols) * 4);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int col = 0; col < bgr.cols; ++col) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(r, col);
      // Inverted CMYK with no black ink: C' = R, M' = G, Y' = B, K' = 255.
      row[col * 4 + 0] = p[2], row[col * 4 + 1] = p[1], row[col * 4 + 2] = p[0],
                    row[col * 4 + 3] = 255;
    }
    JSAMPROW pointer = row.data();
    jpeg_write_scanlines(&info, &pointer, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  std::fclose(file);
}

TEST(HostileUserDataTest, CmykJpegsAreDecodedAndTheOctomapWarningNamesARealKey) {
  Generator g(41);
  for (size_t i = 0; i < kInstances; ++i) {
    Case c;
    std::string output;
    std::vector<std::string> list = Lines(ReadText(c.sequence + "/rgb.txt"));
    for (std::string& line : list) {
      if (line.empty() || line[0] == '#') continue;
      const std::string path = c.sequence + "/" + line.substr(line.find(' ') + 1);
      const std::string jpeg = path.substr(0, path.size() - 4) + "_cmyk.jpg";
      WriteCmykJpeg(jpeg, cv::imread(path, cv::IMREAD_COLOR));
      line = line.substr(0, line.find(' ') + 1) + jpeg.substr(c.sequence.size() + 1);
    }
    WriteText(c.sequence + "/rgb.txt", Join(list));
    const bool octomap_off = g.Below(2) == 0;
    ASSERT_EQ(c.Build(octomap_off ? "--set octomap.enabled=false" : "", &output), 0) << output;
    // Every configuration key a warning names exists.
    std::set<std::string> known;
    for (const ConfigKeyInfo& key : ListConfigKeys()) known.insert(key.name);
    const std::regex key_pattern("\\(([a-z_]+\\.[a-z_.]+)=");
    for (std::sregex_iterator it(output.begin(), output.end(), key_pattern), end; it != end; ++it) {
      EXPECT_EQ(known.count((*it)[1]), 1u) << (*it)[1] << " is no key\n" << output;
    }
    if (octomap_off) {
      EXPECT_NE(output.find("(octomap.enabled="), std::string::npos) << output;
    }
  }
}

}  // namespace
}  // namespace stillmap
