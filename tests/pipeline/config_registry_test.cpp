// The configuration registry against the options structs themselves: every field of every options
// struct has a key (counted independently of VisitFields, by aggregate initialization), keys are
// unique, config.yaml reads back to the same value in every field, and validation messages name
// keys that exist.
#include <gtest/gtest.h>

#include <cstdio>
#include <regex>
#include <set>
#include <typeinfo>
#include <utility>

#include "stillmap/io/error.h"
#include "stillmap/io/option_fields.h"
#include "stillmap/pipeline/config.h"
#include "test_util.h"

namespace stillmap {
// Declared only (used in unevaluated contexts): outside the anonymous namespace.
namespace testing {

// The number of fields of an aggregate: the most initializers `T{...}` accepts.
struct AnyValue {
  template <typename T>
  operator T&() const;  // NOLINT(google-explicit-constructor): converts to any field's type
};

template <typename T, typename = void, typename... Args>
struct BraceInitializable : std::false_type {};
template <typename T, typename... Args>
struct BraceInitializable<T, std::void_t<decltype(T{std::declval<Args>()...})>, Args...>
    : std::true_type {};

template <typename T, size_t... I>
constexpr bool InitializableWith(std::index_sequence<I...> /*unused*/) {
  return BraceInitializable<T, void, decltype((void)I, AnyValue{})...>::value;
}

template <typename T, size_t N = 0>
constexpr size_t AggregateFieldCount() {
  if constexpr (!InitializableWith<T>(std::make_index_sequence<N + 1>{})) {
    return N;
  } else {
    return AggregateFieldCount<T, N + 1>();
  }
}

}  // namespace testing

namespace {

using testing::AggregateFieldCount;

template <typename T>
struct FieldCount {
  static constexpr size_t kValue = AggregateFieldCount<T>();
};
// GridOptions holds an optional Eigen vector, whose unconstrained converting constructor clang
// instantiates (and fails on) while counting: its count is checked by a structured binding
// instead, which compiles only with exactly as many names as the struct has fields.
template <>
struct FieldCount<GridOptions> {
  static constexpr size_t kValue = 18;
};
[[maybe_unused]] void GridOptionsHasEighteenFields(GridOptions& options) {
  [[maybe_unused]] auto& [a, b, c, d, e, f, g, h, i, j, k, l, m, n, o, p, q, r] = options;
}

template <typename Options>
size_t VisitedFieldCount();

// Counts the fields a VisitFields names directly (a member struct counts once) and checks each
// member struct's own VisitFields the same way.
class DirectFieldCounter {
 public:
  template <typename T>
  void operator()(const char* /*name*/, T& /*field*/, const char* /*help*/) {
    ++count_;
  }
  template <typename Options>
  void Nested(const char* /*prefix*/, Options& /*options*/) {
    Member<Options>();
  }
  template <typename Options>
  void Section(const char* /*section*/, Options& /*options*/, const char* /*prefix*/ = "") {
    Member<Options>();
  }
  size_t count() const { return count_; }

 private:
  template <typename Options>
  void Member() {
    ++count_;
    EXPECT_EQ(VisitedFieldCount<Options>(), FieldCount<Options>::kValue)
        << typeid(Options).name() << ": a field without a configuration key";
  }
  size_t count_ = 0;
};

template <typename Options>
size_t VisitedFieldCount() {
  Options options{};
  DirectFieldCounter counter;
  Options::VisitFields(options, counter);
  return counter.count();
}

// The check can fail: a struct whose VisitFields leaves a field out.
struct ToyOptions {
  int listed = 1;
  double forgotten = 2.0;
  template <typename Self, typename Visitor>
  static void VisitFields(Self& self, Visitor& visit) {
    visit("listed", self.listed, "a field");
  }
};

TEST(ConfigRegistryTest, EveryFieldOfEveryOptionsStructHasAKey) {
  EXPECT_EQ(AggregateFieldCount<ToyOptions>(), 2u);
  EXPECT_EQ(VisitedFieldCount<ToyOptions>(), 1u);
  EXPECT_EQ(AggregateFieldCount<TrackerOptions>(), 11u);  // the counter itself, on a known struct
  // Recursively: BuildConfig and each options struct it holds.
  EXPECT_EQ(VisitedFieldCount<BuildConfig>(), FieldCount<BuildConfig>::kValue);
}

// Every key with the address of its field, from a full visit.
class FieldAddresses : public OptionVisitor<FieldAddresses> {
 public:
  template <typename T>
  void operator()(const char* name, T& field, const char* help) {
    EXPECT_GT(std::string(help).size(), 5u) << KeyOf(name) << " has no help";
    fields.emplace_back(KeyOf(name), static_cast<const void*>(&field));
  }
  std::vector<std::pair<std::string, const void*>> fields;
};

TEST(ConfigRegistryTest, KeysAndFieldsAreOneToOne) {
  BuildConfig config;
  FieldAddresses visitor;
  BuildConfig::VisitFields(config, visitor);
  std::set<std::string> keys;
  std::set<const void*> addresses;
  for (const auto& [key, address] : visitor.fields) {
    EXPECT_TRUE(keys.insert(key).second) << "key twice: " << key;
    EXPECT_TRUE(addresses.insert(address).second) << "field under two keys: " << key;
    EXPECT_EQ(std::count(key.begin(), key.end(), '.'), 1) << "not section.name: " << key;
  }
  EXPECT_EQ(ListConfigKeys().size(), visitor.fields.size());
}

// Each field as text, written with printf (not the registry's own formatting).
class FieldTexts : public OptionVisitor<FieldTexts> {
 public:
  template <typename T>
  void operator()(const char* name, const T& field, const char* /*help*/) {
    texts.emplace_back(KeyOf(name), Text(field));
  }
  std::vector<std::pair<std::string, std::string>> texts;

 private:
  static std::string Print(const char* format, double value) {
    char text[64];
    std::snprintf(text, sizeof(text), format, value);
    return text;
  }
  static std::string Text(double v) { return Print("%.17g", v); }
  static std::string Text(float v) { return Print("%.9g", v); }
  static std::string Text(int v) { return std::to_string(v); }
  static std::string Text(size_t v) { return std::to_string(v); }
  static std::string Text(bool v) { return v ? "T" : "F"; }
  static std::string Text(const std::string& v) { return "'" + v + "'"; }
  static std::string Text(OutlineMode v) { return std::to_string(static_cast<int>(v)); }
  static std::string Text(PlanarMotionMode v) { return std::to_string(static_cast<int>(v)); }
  template <typename T, size_t N>
  static std::string Text(const std::array<T, N>& v) {
    std::string text;
    for (const T& item : v) text += Text(item) + " ";
    return text;
  }
  static std::string Text(const Eigen::Vector4d& v) {
    return Text(std::array<double, 4>{v[0], v[1], v[2], v[3]});
  }
  template <typename T>
  static std::string Text(const std::optional<T>& v) {
    return v ? Text(*v) : std::string("unset");
  }
};

std::vector<std::pair<std::string, std::string>> TextsOf(const BuildConfig& config) {
  FieldTexts visitor;
  BuildConfig::VisitFields(config, visitor);
  return visitor.texts;
}

// Moves every field off its default (values need not be valid, only readable).
class Perturber : public OptionVisitor<Perturber> {
 public:
  void operator()(const char* /*name*/, double& v, const char* /*help*/) { v = v * 1.5 + 0.123; }
  void operator()(const char* /*name*/, float& v, const char* /*help*/) { v = v * 1.5f + 0.125f; }
  void operator()(const char* /*name*/, int& v, const char* /*help*/) { v += 3; }
  void operator()(const char* /*name*/, size_t& v, const char* /*help*/) { v += 2; }
  void operator()(const char* /*name*/, bool& v, const char* /*help*/) { v = !v; }
  void operator()(const char* /*name*/, OutlineMode& v, const char* /*help*/) {
    v = v == OutlineMode::kEdges ? OutlineMode::kBox : OutlineMode::kEdges;
  }
  void operator()(const char* /*name*/, PlanarMotionMode& v, const char* /*help*/) {
    v = v == PlanarMotionMode::kOn ? PlanarMotionMode::kOff : PlanarMotionMode::kOn;
  }
  void operator()(const char* name, std::string& v, const char* /*help*/) {
    const std::string key = KeyOf(name);
    v = key == "camera.preset" ? "bonn" : key == "detector.levels" ? "chair=low,book=high" : "obj";
  }
  void operator()(const char* /*name*/, std::optional<int>& v, const char* /*help*/) { v = 321; }
  void operator()(const char* /*name*/, std::optional<double>& v, const char* /*help*/) {
    v = 0.1 + 1e-13;  // not short in decimal
  }
  void operator()(const char* /*name*/, std::optional<std::array<double, 5>>& v,
                  const char* /*help*/) {
    v = std::array<double, 5>{0.1, -0.2, 1e-3, 2e-3, 1.0 / 3.0};
  }
  void operator()(const char* /*name*/, std::optional<Eigen::Vector4d>& v, const char* /*help*/) {
    v = Eigen::Vector4d(0.0, -0.1, 1.0 / 3.0, 0.5);
  }
  void operator()(const char* /*name*/, std::array<double, 16>& v, const char* /*help*/) {
    for (double& x : v) x = x / 3.0 + 0.1;
  }
};

TEST(ConfigRegistryTest, ConfigYamlReadsBackToTheSameValueInEveryField) {
  for (const bool perturbed : {false, true}) {
    BuildConfig config;
    if (perturbed) {
      Perturber perturber;
      BuildConfig::VisitFields(config, perturber);
      const auto defaults = TextsOf(BuildConfig{}), changed = TextsOf(config);
      for (size_t i = 0; i < defaults.size(); ++i) {
        EXPECT_NE(defaults[i].second, changed[i].second) << defaults[i].first << " not moved";
      }
    }
    testing::TempDir dir;
    testing::WriteText(dir / "config.yaml", ConfigToYaml(config));
    BuildConfig read_back;
    ApplyConfigFile(&read_back, dir / "config.yaml");
    const auto expected = TextsOf(config), actual = TextsOf(read_back);
    ASSERT_EQ(expected.size(), actual.size());
    for (size_t i = 0; i < expected.size(); ++i) {
      EXPECT_EQ(expected[i], actual[i]) << (perturbed ? "perturbed" : "defaults");
    }
  }
}

TEST(ConfigRegistryTest, KeysOfEarlierReleasesStillSetTheirFields) {
  const std::vector<std::pair<std::string, std::string>> renamed = {
      {"mapping.voxel_leaf", "mapping.voxel_leaf_size"},
      {"tracking.search_radius", "tracking.search_radius_px"},
      {"masking.depth_difference", "masking.max_depth_difference_m"},
      {"keyframes.selection", "keyframes.enabled"}};
  for (const auto& [former, current] : renamed) {
    BuildConfig by_former, by_current;
    const std::string value = former == "keyframes.selection" ? "false" : "0.25";
    SetConfigValue(&by_former, former, value, "test");
    SetConfigValue(&by_current, current, value, "test");
    EXPECT_EQ(TextsOf(by_former), TextsOf(by_current)) << former;
    EXPECT_NE(TextsOf(by_current), TextsOf(BuildConfig{})) << current;
  }
}

// Whatever a single out-of-range value makes Validate say names keys a user can set.
TEST(ConfigRegistryTest, ValidationMessagesNameKeysThatExist) {
  std::set<std::string> keys;
  for (const ConfigKeyInfo& key : ListConfigKeys()) keys.insert(key.name);
  const std::regex key_pattern(
      "\\b(run|poses|map|camera|sequence|mapping|octomap|tracking|masking|keyframes|"
      "grid|mesh|render|detector|eval|merge|final_poses)\\.[a-z0-9_]+");
  size_t refused = 0;
  for (const std::string& key : keys) {
    for (const std::string value : {"-1000000000", "0", "1000000000"}) {
      BuildConfig config;
      try {
        SetConfigValue(&config, key, value, "test");
      } catch (const InputError&) {
        continue;  // not a number for this key, or outside its type
      }
      const std::string message = testing::ErrorOf([&] { config.Validate(); });
      if (message.empty()) continue;
      ++refused;
      size_t named = 0;
      for (auto it = std::sregex_iterator(message.begin(), message.end(), key_pattern);
           it != std::sregex_iterator(); ++it, ++named) {
        EXPECT_EQ(keys.count(it->str()), 1u) << key << "=" << value << ": " << message;
      }
      EXPECT_GT(named, 0u) << key << "=" << value << ": " << message;
    }
  }
  EXPECT_GT(refused, 100u);
}

// The option registry (io/option_names.h) names every field by its configuration key.
class RegistryCheck : public OptionVisitor<RegistryCheck> {
 public:
  explicit RegistryCheck(const BuildConfig& config) : config_(config) {}
  template <typename T>
  void operator()(const char* name, const T& field, const char* /*help*/) {
    EXPECT_EQ(OptionKey(config_, field), KeyOf(name));
    ++count_;
  }
  size_t count() const { return count_; }

 private:
  const BuildConfig& config_;
  size_t count_ = 0;
};

TEST(ConfigRegistryTest, TheRegistryNamesEveryFieldByItsKey) {
  RegisterConfigKeys();
  const BuildConfig config;
  RegistryCheck check(config);
  check.Root(config);
  EXPECT_EQ(check.count(), ListConfigKeys().size());
  // From the struct that holds a field, however deep, and from a member pointer.
  EXPECT_EQ(OptionKey(config.tracking, config.tracking.local_map.local_window),
            "tracking.local_window");
  EXPECT_EQ(OptionKey(config.tracking.loops, config.tracking.loops.place.tables),
            "tracking.place_tables");
  EXPECT_EQ(OptionKey(&GridOptions::resolution), "grid.resolution");
  EXPECT_EQ(OptionKey(&BackProjectionOptions::max_depth), "mapping.max_depth");
  EXPECT_EQ(OptionKey(&YoloxOptions::score_threshold), "detector.score_threshold");
  EXPECT_EQ(OptionKey(&FastestOptions::score_threshold), "detector.fastest_score_threshold");
  EXPECT_EQ(OptionKey(&RpeOptions::delta), "eval.rpe_delta");
}

}  // namespace
}  // namespace stillmap
