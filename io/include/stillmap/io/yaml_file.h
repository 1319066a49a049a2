// One strict reader for the YAML files a user writes (camera.yaml, --config, grid.yaml), so that
// every such file refuses the same things with a message naming the file and line: more than one
// document, a key given twice, aliases that refer to themselves, and nesting deeper than a
// settings file needs.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

namespace stillmap {

// Reads `path` (a `what`, e.g. "camera file", for the messages) and returns its one document (a
// null node when the file is empty). Throws InputError naming the file and line for an unreadable
// file, invalid YAML, a second document, a key given twice in one map, an alias that refers to a
// node it is inside of, or nesting deeper than kMaxYamlDepth.
YAML::Node LoadYamlFile(const std::string& path, const std::string& what);

// yaml-cpp's message (YAML::Exception::msg) in the user's words: what is wrong and how to fix it.
std::string YamlProblem(const std::string& message);

// How deep maps and lists may nest in a file read by LoadYamlFile (a settings file needs 3).
constexpr int kMaxYamlDepth = 32;

}  // namespace stillmap
