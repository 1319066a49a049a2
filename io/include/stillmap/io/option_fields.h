// How an options struct lists its fields once, for the configuration (pipeline/config.h): a
// static member template
//
//   template <typename Self, typename Visitor>
//   static void VisitFields(Self& self, Visitor& visit) {
//     visit("leaf_size", self.leaf_size, "voxel edge of the colored cloud [m]");
//     visit.Nested("pnp_", self.pnp);          // the fields of a member struct, keys prefixed
//     visit.Section("octomap", self.occupancy);  // ... or under a section of their own
//   }
//
// called with `Self` = the struct or its const version. Every field appears exactly once, in
// declaration order, under its own name; the help text gives the unit and, for thresholds from a
// paper, the paper. A visitor derives from OptionVisitor, which keeps the key path; one that
// needs the structs it passes through defines EnterStruct(options) and LeaveStruct().
#pragma once

#include <string>
#include <type_traits>

namespace stillmap {

template <typename Derived>
class OptionVisitor {
 public:
  // The fields of `options` with their keys prefixed by `prefix` in the current section.
  template <typename Options>
  void Nested(const char* prefix, Options& options) {
    VisitUnder(prefix_ + prefix, options);
  }

  // The fields of `options` under "section." (plus `prefix`), wherever the visit is.
  template <typename Options>
  void Section(const char* section, Options& options, const char* prefix = "") {
    VisitUnder(std::string(section) + "." + prefix, options);
  }

  // The fields of `options` as the top of the key path (the configuration itself).
  template <typename Options>
  void Root(Options& options) {
    VisitUnder("", options);
  }

  // Called around the fields of each struct visited, innermost last (no-ops unless shadowed).
  template <typename Options>
  void EnterStruct(Options& /*options*/) {}
  void LeaveStruct() {}

 protected:
  // The full key of a field named `name` where the visit is.
  std::string KeyOf(const char* name) const { return prefix_ + name; }

 private:
  // Visits `options` with `prefix` as the key path, then restores the current one.
  template <typename Options>
  void VisitUnder(std::string prefix, Options& options) {
    prefix_.swap(prefix);
    Derived& derived = static_cast<Derived&>(*this);
    derived.EnterStruct(options);
    std::remove_const_t<Options>::VisitFields(options, derived);
    derived.LeaveStruct();
    prefix_.swap(prefix);
  }

  std::string prefix_;
};

}  // namespace stillmap
