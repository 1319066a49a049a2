// The cloud files read back by the tools users open them with: pcl-tools' pcl_pcd2ply and
// pcl_ply2pcd (Debian's pcl-tools, installed by scripts/setup.sh) convert them with the same
// points and colours.
#include "stillmap/io/cloud_files.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "test_util.h"

namespace stillmap {
namespace {

using testing::RunCommand;
using testing::TempDir;

// Points with distinct positions and colours, every channel's extremes among them.
std::vector<VoxelPoint> Points() {
  std::vector<VoxelPoint> points;
  for (int i = 0; i < 50; ++i) {
    const auto c = static_cast<std::uint8_t>(i * 5);
    points.push_back(
        {Eigen::Vector3f(0.25f * static_cast<float>(i) - 3.0f, -1.5f + 0.01f * i,
                         0.125f * static_cast<float>(i % 7)),
         {c, static_cast<std::uint8_t>(255 - c), static_cast<std::uint8_t>(i % 2 * 255)},
         1});
  }
  return points;
}

// The vertices of an ASCII PLY with properties x y z red green blue (and nothing else per
// vertex), parsed here independently of PCL.
std::vector<VoxelPoint> ReadAsciiPly(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  size_t count = 0;
  std::vector<std::string> properties;
  bool in_vertex = false;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string word, type, name;
    words >> word;
    if (word == "element") {
      size_t n = 0;
      words >> name >> n;
      in_vertex = name == "vertex";  // pcl-tools add face and camera elements after it
      if (in_vertex) count = n;
    } else if (word == "property" && in_vertex) {
      words >> type >> name;
      properties.push_back(name);
    }
  }
  EXPECT_EQ(properties, (std::vector<std::string>{"x", "y", "z", "red", "green", "blue"}));
  std::vector<VoxelPoint> points(count);
  for (VoxelPoint& p : points) {
    int r = -1, g = -1, b = -1;
    in >> p.position.x() >> p.position.y() >> p.position.z() >> r >> g >> b;
    p.rgb = {static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(g),
             static_cast<std::uint8_t>(b)};
  }
  EXPECT_TRUE(in) << path << ": fewer vertices than its header says";
  return points;
}

void ExpectSamePoints(const std::vector<VoxelPoint>& expected, const std::vector<VoxelPoint>& got,
                      const std::string& what) {
  ASSERT_EQ(got.size(), expected.size()) << what;
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_LT((got[i].position - expected[i].position).norm(), 1e-5f) << what << ", point " << i;
    EXPECT_EQ(got[i].rgb, expected[i].rgb) << what << ", point " << i;
  }
}

bool HasTool(const std::string& tool) {
  std::string output;
  return RunCommand("command -v " + tool, &output) == 0;
}

TEST(CloudFilesTest, PclToolsConvertThePcdAndPlyWithTheSamePointsAndColours) {
  ASSERT_TRUE(HasTool("pcl_pcd2ply") && HasTool("pcl_ply2pcd"))
      << "pcl_pcd2ply / pcl_ply2pcd not found: install Debian's pcl-tools (scripts/setup.sh does)";
  const TempDir dir;
  const std::vector<VoxelPoint> points = Points();
  WriteCloudFiles(dir / "map.ply", dir / "map.pcd", points, 0.05, "test frame");
  std::string output;
  ASSERT_EQ(RunCommand("pcl_pcd2ply -format 0 " + (dir / "map.pcd") + " " + (dir / "from_pcd.ply"),
                       &output),
            0)
      << output;
  ExpectSamePoints(points, ReadAsciiPly(dir / "from_pcd.ply"), "pcl_pcd2ply of map.pcd");
  // And back: PLY -> PCD by pcl-tools, read by PCL's loader.
  ASSERT_EQ(RunCommand("pcl_ply2pcd -format 1 " + (dir / "map.ply") + " " + (dir / "from_ply.pcd"),
                       &output),
            0)
      << output;
  ExpectSamePoints(points, ReadCloud(dir / "from_ply.pcd"), "pcl_ply2pcd of map.ply");
  // The PCD declares its packed colour as PCL does.
  EXPECT_NE(testing::ReadText(dir / "map.pcd").find("TYPE F F F F\n"), std::string::npos);
}

}  // namespace
}  // namespace stillmap
