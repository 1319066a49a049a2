#include "stillmap/io/yaml_file.h"

#include <yaml-cpp/depthguard.h>

#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "stillmap/io/error.h"
#include "stillmap/io/input_files.h"

namespace stillmap {
namespace {

// Checks one node and what it holds: no key twice in a map, no alias back to a node on the path
// from the root (yaml-cpp resolves it into a cycle that any walk follows forever), depth bounded.
class Checker {
 public:
  Checker(const std::string& path, const std::string& what) : path_(path), what_(what) {}

  void Check(const YAML::Node& node) {
    const int line = node.Mark().line + 1;
    for (const YAML::Node& outer : path_nodes_) {
      if (outer.is(node)) {
        throw InputError(WhereInFile(path_, line) + ": the " + what_ +
                         " has an alias that refers to a node it is inside of; write the values "
                         "out instead");
      }
    }
    if (static_cast<int>(path_nodes_.size()) >= kMaxYamlDepth) {
      throw InputError(WhereInFile(path_, line) + ": the " + what_ + " nests more than " +
                       std::to_string(kMaxYamlDepth) + " levels of maps and lists");
    }
    if (!node.IsMap() && !node.IsSequence()) return;
    path_nodes_.push_back(node);
    if (node.IsMap()) {
      std::set<std::string> keys;
      for (const auto& item : node) {
        CheckKey(item.first, &keys);
        Check(item.second);
      }
    } else {
      for (const YAML::Node& item : node) Check(item);
    }
    path_nodes_.pop_back();
  }

 private:
  void CheckKey(const YAML::Node& key, std::set<std::string>* keys) {
    const std::string where = WhereInFile(path_, key.Mark().line + 1);
    if (!key.IsScalar()) {
      throw InputError(where + ": the " + what_ + " has a key that is not a plain name");
    }
    if (!keys->insert(key.Scalar()).second) {
      throw InputError(where + ": key '" + key.Scalar() + "' is given twice in the " + what_ +
                       "; keep one");
    }
  }

  const std::string& path_;
  const std::string& what_;
  std::vector<YAML::Node> path_nodes_;
};

// True when line `line` (0-based) or the one before it is indented with a tab: yaml-cpp then
// reports whatever the tab made of the structure, not the tab.
bool TabIndented(const std::string& text, int line) {
  std::istringstream in(text);
  std::string current;
  for (int i = 0; std::getline(in, current) && i <= line; ++i) {
    if (i < line - 1) continue;
    const size_t content = current.find_first_not_of(" \t");
    if (current.substr(0, content).find('\t') != std::string::npos) return true;
  }
  return false;
}

}  // namespace

std::string YamlProblem(const std::string& message) {
  struct Problem {
    const char* says;  // a part of yaml-cpp's message
    const char* means;
  };
  static const Problem kProblems[] = {
      {"end of map",
       "a map ('{ ... }' or indented keys) is not closed: a missing '}', or a line "
       "indented wrongly"},
      {"end of sequence", "a list ('[ ... ]') is not closed: a missing ']'"},
      {"tab", "a tab in the indentation: indent with spaces"},
      {"map value",
       "a ':' where no value can start: check the indentation, and quote a value "
       "that holds ': '"},
      {"map key", "a key where none can start: check the indentation"},
      {"block entry", "a '- ' list item where none can start: check the indentation"},
      {"flow end", "a ']' or '}' that closes nothing"},
      {"escape", "a backslash escape YAML does not know inside double quotes: use single quotes"},
      {"hex", "a backslash escape YAML does not know inside double quotes: use single quotes"},
      {"unicode", "a backslash escape YAML does not know inside double quotes: use single quotes"},
      {"in scalar",
       "a quoted text that is not closed, or a character plain text may not hold: "
       "check the quotes"},
      {"anchor not found", "an alias (*name) whose anchor (&name) is not defined before it"},
      {"anchor", "an anchor (&name) YAML does not allow here"},
      {"alias", "an alias (*name) YAML does not allow here"},
      {"tag", "a tag ('!...') YAML does not allow here"},
      {"directive", "a '%' directive YAML does not allow here"},
      {"conversion", "a value of another kind than expected (a number, text, or a list of them)"},
  };
  for (const Problem& problem : kProblems) {
    if (message.find(problem.says) != std::string::npos) return problem.means;
  }
  return "text YAML cannot read here: check the indentation, the ':' after each key and the "
         "quotes";
}

YAML::Node LoadYamlFile(const std::string& path, const std::string& what) {
  CheckInputFile(path, what);
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) throw InputError(path + ": cannot read the " + what);
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(text.str());
  } catch (const YAML::DeepRecursion& e) {
    throw InputError(WhereInFile(path, e.mark.line + 1) + ": the " + what + " nests " +
                     std::to_string(e.depth()) + " levels of maps and lists; at most " +
                     std::to_string(kMaxYamlDepth) + " are allowed");
  } catch (const YAML::Exception& e) {
    const bool tab = TabIndented(text.str(), e.mark.line);
    throw InputError(WhereInFile(path, e.mark.line + 1) + ": not valid YAML: " +
                     (tab ? "a tab in the indentation: indent with spaces" : YamlProblem(e.msg)));
  }
  if (documents.empty()) return YAML::Node();
  if (documents.size() > 1) {
    throw InputError(WhereInFile(path, documents[1].Mark().line + 1) + ": the " + what + " holds " +
                     std::to_string(documents.size()) +
                     " YAML documents; it must hold one (remove what follows the '---' or '...')");
  }
  Checker(path, what).Check(documents[0]);
  return documents[0];
}

}  // namespace stillmap
