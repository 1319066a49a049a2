// Parts of report.json that a build's and a merge's reports share.
#pragma once

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "stillmap/pipeline/build_result.h"
#include "stillmap/pipeline/config.h"

namespace stillmap {

nlohmann::json StatisticsJson(const ErrorStatistics& statistics);
// The map's figures with the options that explain them.
nlohmann::json MapJson(const MapFigures& map, const BuildConfig& config);
// null without a mesh.
nlohmann::json MeshJson(const std::optional<MeshFigures>& mesh, const MapMeshOptions& options);
std::vector<double> RowMajor(const Eigen::Isometry3d& transform);
nlohmann::json FloorJson(const FloorPlane& floor);
nlohmann::json GridJson(const OccupancyGrid& grid);

}  // namespace stillmap
