#include "stillmap/io/option_names.h"

#include <map>
#include <mutex>
#include <utility>

namespace stillmap {
namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::pair<std::type_index, std::ptrdiff_t>, std::string> keys;  // "" = ambiguous
};

Registry& TheRegistry() {
  static Registry registry;
  return registry;
}

}  // namespace

void RegisterOptionKey(std::type_index options, std::ptrdiff_t offset, const std::string& key) {
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  const auto [it, inserted] = registry.keys.emplace(std::make_pair(options, offset), key);
  if (!inserted && it->second != key) it->second.clear();
}

std::string RegisteredOptionKey(std::type_index options, std::ptrdiff_t offset) {
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  const auto it = registry.keys.find(std::make_pair(options, offset));
  return it == registry.keys.end() ? std::string() : it->second;
}

}  // namespace stillmap
