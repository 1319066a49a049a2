// The configuration key of an options field, for messages and checks, from the one registry of
// keys (the structs' VisitFields, io/option_fields.h), so that no module types a key by hand:
//
//   throw InputError(OptionKey(*this, keyframe_ratio) + " must lie in (0, 1]");
//   fmt::format("raise {}", OptionKey(&GridOptions::resolution));
//
// gives "tracking.keyframe_ratio" and "grid.resolution" once the configuration has registered
// its keys (pipeline does when a build, a merge or a configuration is checked), else the field's
// key within its own struct ("keyframe_ratio"), as for a component used on its own.
#pragma once

#include <cstddef>
#include <string>
#include <typeindex>
#include <typeinfo>

#include "stillmap/io/option_fields.h"

namespace stillmap {

// The registry: (struct type, byte offset of a field in it) -> full key. Each field is recorded
// under every struct that encloses it in the configuration; a place recorded twice under
// different keys names nothing (the local key is used).
void RegisterOptionKey(std::type_index options, std::ptrdiff_t offset, const std::string& key);
std::string RegisteredOptionKey(std::type_index options, std::ptrdiff_t offset);  // "" if none

namespace option_names {

// The key of the field at `field` within `options`, from the struct's own VisitFields.
class LocalKey : public OptionVisitor<LocalKey> {
 public:
  explicit LocalKey(const void* field) : field_(field) {}
  template <typename T>
  void operator()(const char* name, const T& field, const char* /*help*/) {
    if (static_cast<const void*>(&field) == field_) key_ = KeyOf(name);
  }
  const std::string& key() const { return key_; }

 private:
  const void* field_;
  std::string key_;
};

}  // namespace option_names

// `field` must be a field of `options` (at any depth of its nested structs).
template <typename Options, typename Field>
std::string OptionKey(const Options& options, const Field& field) {
  const std::ptrdiff_t offset =
      reinterpret_cast<const char*>(&field) - reinterpret_cast<const char*>(&options);
  std::string key = RegisteredOptionKey(typeid(Options), offset);
  if (!key.empty()) return key;
  option_names::LocalKey local(&field);
  local.Root(options);
  return local.key().empty() ? std::string("(unregistered option)") : local.key();
}

// OptionKey bound to one options struct: `const OptionKeys key(*this); key(keyframe_ratio)`.
template <typename Options>
class OptionKeys {
 public:
  explicit OptionKeys(const Options& options) : options_(options) {}
  template <typename Field>
  std::string operator()(const Field& field) const {
    return OptionKey(options_, field);
  }

 private:
  const Options& options_;
};

// The same from a member pointer, where no instance is at hand.
template <typename Options, typename Field>
std::string OptionKey(Field Options::*member) {
  static const Options kProbe{};
  return OptionKey(kProbe, kProbe.*member);
}

}  // namespace stillmap
