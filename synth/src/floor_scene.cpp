// The synthetic floor's building: walls with doors, floors and ceilings, the four rooms' furniture
// and the people walking in rooms and corridors (floor_plan.h has the layout).
#include <cmath>
#include <vector>

#include "floor_plan.h"
#include "scene_geometry.h"
#include "scene_parts.h"
#include "scene_textures.h"

namespace stillmap::synth {

bool IsFloorScenario(const std::string& scenario) {
  return scenario == "floor" || scenario == "floor_lost";
}

const std::array<FloorRoom, 4>& FloorRooms() {
  static const std::array<FloorRoom, 4> kRooms{{
      {"office", {0.0f, 0.0f, 8.0f - kFloorWallHalf, 4.0f - kFloorWallHalf}, 6.5f, true},
      {"library", {8.0f + kFloorWallHalf, 0.0f, 16.0f, 4.0f - kFloorWallHalf}, 9.5f, true},
      {"meeting", {8.0f + kFloorWallHalf, 10.0f + kFloorWallHalf, 16.0f, 14.0f}, 12.0f, false},
      {"kitchen", {0.0f, 10.0f + kFloorWallHalf, 8.0f - kFloorWallHalf, 14.0f}, 4.0f, false},
  }};
  return kRooms;
}

namespace {

constexpr float kH = kFloorWallHeight;

// Adds the floor's objects: walls split into panels, each panel its own texture when asked.
class FloorBuilder {
 public:
  FloorBuilder(cv::RNG& rng, Scene* scene) : rng_(rng), scene_(scene), add_(scene) {}

  // A wall face from `a` to `b` (seen from either side), with door openings at the x or y
  // positions `doors` along it. Panels of at most 2.7 m: `paint` gives each panel a poster wall of
  // its own; without it, `plain` is repeated every metre.
  void WallFace(const std::string& name, const Eigen::Vector2f& a, const Eigen::Vector2f& b,
                const std::vector<float>& doors, const cv::Scalar* paint, std::uint16_t plain) {
    const Eigen::Vector2f along = (b - a).normalized();
    const float length = (b - a).norm();
    std::vector<std::pair<float, float>> spans;  // solid stretches, metres from a
    float start = 0.0f;
    for (float door : doors) {
      const float middle =
          std::abs(along.x()) > 0.5f ? (door - a.x()) / along.x() : (door - a.y()) / along.y();
      spans.emplace_back(start, middle - kFloorDoorWidth / 2);
      Panel(name + "_lintel", a, along, middle - kFloorDoorWidth / 2, middle + kFloorDoorWidth / 2,
            kFloorDoorHeight, kH, paint, plain);
      start = middle + kFloorDoorWidth / 2;
    }
    spans.emplace_back(start, length);
    int index = 0;
    for (const auto& [from, to] : spans) {
      const int panels = static_cast<int>(std::ceil((to - from) / 2.7f - 1e-3f));
      for (int p = 0; p < panels; ++p) {
        const float s0 = from + (to - from) * static_cast<float>(p) / static_cast<float>(panels);
        const float s1 =
            from + (to - from) * static_cast<float>(p + 1) / static_cast<float>(panels);
        Panel(name + "_" + std::to_string(index++), a, along, s0, s1, 0.0f, kH, paint, plain);
      }
    }
  }

  // A horizontal rectangle at height z (floor or ceiling), texture repeated every `tile_m`.
  void Slab(const std::string& name, const FloorRect& r, float z, std::uint16_t material,
            float tile_m) {
    TriangleMesh slab = MakeQuad({r.x0, r.y0, z}, {r.x1 - r.x0, 0, 0}, {0, r.y1 - r.y0, 0});
    for (auto& uv : slab.uvs) uv = uv.cwiseProduct(Eigen::Vector2f(r.x1 - r.x0, r.y1 - r.y0));
    for (auto& uv : slab.uvs) uv /= tile_m;
    add_(name, slab, material);
  }

  void Add(const std::string& name, TriangleMesh mesh, std::uint16_t material) {
    add_(name, std::move(mesh), material);
  }
  std::uint16_t Material(const cv::Mat& texture) { return AddMaterial(scene_, texture); }
  cv::RNG& rng() { return rng_; }

 private:
  // The part of a wall face between s0 and s1 metres along it, from height z0 to z1.
  void Panel(const std::string& name, const Eigen::Vector2f& a, const Eigen::Vector2f& along,
             float s0, float s1, float z0, float z1, const cv::Scalar* paint, std::uint16_t plain) {
    const Eigen::Vector2f p0 = a + along * s0;
    const Eigen::Vector2f span = along * (s1 - s0);
    TriangleMesh quad = MakeQuad({p0.x(), p0.y(), z1}, {span.x(), span.y(), 0}, {0, 0, z0 - z1});
    std::uint16_t material = plain;
    if (paint != nullptr) {
      material = Material(WallTexture(rng_, *paint));
    } else {
      for (auto& uv : quad.uvs) uv = uv.cwiseProduct(Eigen::Vector2f(s1 - s0, z1 - z0));
    }
    add_(name, quad, material);
  }

  cv::RNG& rng_;
  Scene* scene_;
  StaticAdder add_;
};

// The walls: the building's outside, the rooms' inner faces (posters), the corridor's faces
// (plain, with door frames) and the core (blank).
void AddWalls(FloorBuilder& build, std::uint16_t corridor_paint, std::uint16_t core_paint,
              std::uint16_t trim) {
  const std::array<cv::Scalar, 4> paints{cv::Scalar(200, 215, 222), cv::Scalar(150, 190, 200),
                                         cv::Scalar(215, 195, 175), cv::Scalar(180, 215, 190)};
  for (size_t k = 0; k < FloorRooms().size(); ++k) {
    const FloorRoom& room = FloorRooms()[k];
    const FloorRect& r = room.inside;
    const cv::Scalar* paint = &paints[k];
    const std::string name = room.name;
    const std::vector<float> door{room.door_x};
    const std::vector<float> none;
    build.WallFace(name + "_south", {r.x0, r.y0}, {r.x1, r.y0},
                   room.south_of_corridor ? none : door, paint, 0);
    build.WallFace(name + "_north", {r.x1, r.y1}, {r.x0, r.y1},
                   room.south_of_corridor ? door : none, paint, 0);
    build.WallFace(name + "_west", {r.x0, r.y1}, {r.x0, r.y0}, none, paint, 0);
    build.WallFace(name + "_east", {r.x1, r.y0}, {r.x1, r.y1}, none, paint, 0);
  }
  // The corridor's outer faces: the rooms' walls seen from the corridor, and the two ends.
  const float south = kCorridorSouthWall + kFloorWallHalf,
              north = kCorridorNorthWall - kFloorWallHalf;
  build.WallFace("corridor_south", {0, south}, {16, south}, {6.5f, 9.5f}, nullptr, corridor_paint);
  build.WallFace("corridor_north", {16, north}, {0, north}, {12.0f, 4.0f}, nullptr, corridor_paint);
  build.WallFace("corridor_west", {0, north}, {0, south}, {}, nullptr, corridor_paint);
  build.WallFace("corridor_east", {16, south}, {16, north}, {}, nullptr, corridor_paint);
  const FloorRect& c = kFloorCore;
  build.WallFace("core_south", {c.x0, c.y0}, {c.x1, c.y0}, {}, nullptr, core_paint);
  build.WallFace("core_east", {c.x1, c.y0}, {c.x1, c.y1}, {}, nullptr, core_paint);
  build.WallFace("core_north", {c.x1, c.y1}, {c.x0, c.y1}, {}, nullptr, core_paint);
  build.WallFace("core_west", {c.x0, c.y1}, {c.x0, c.y0}, {}, nullptr, core_paint);
  // Door frames: jambs and lintel across the wall's thickness, trim around the corridor side.
  for (const FloorRoom& room : FloorRooms()) {
    const float y = room.south_of_corridor ? kCorridorSouthWall : kCorridorNorthWall;
    const float side = room.south_of_corridor ? 1.0f : -1.0f;  // towards the corridor
    const float x0 = room.door_x - kFloorDoorWidth / 2, x1 = room.door_x + kFloorDoorWidth / 2;
    TriangleMesh frame;
    for (float x : {x0, x1}) {
      frame.Append(MakeQuad({x, y - kFloorWallHalf, kFloorDoorHeight}, {0, 2 * kFloorWallHalf, 0},
                            {0, 0, -kFloorDoorHeight}));
      frame.Append(MakeBox({x + (x == x0 ? -0.04f : 0.04f), y + side * 0.07f, 1.07f},
                           {0.08f, 0.04f, 2.14f}, 0.5f));
    }
    frame.Append(MakeQuad({x0, y - kFloorWallHalf, kFloorDoorHeight}, {kFloorDoorWidth, 0, 0},
                          {0, 2 * kFloorWallHalf, 0}));
    frame.Append(MakeBox({room.door_x, y + side * 0.07f, kFloorDoorHeight + 0.04f},
                         {kFloorDoorWidth + 0.16f, 0.04f, 0.08f}, 0.5f));
    build.Add(std::string(room.name) + "_door_frame", frame, trim);
    // The door leaf, open into the room against the hinge side.
    build.Add(std::string(room.name) + "_door",
              Box(x1 + 0.02f, y - side * (kFloorWallHalf + 0.45f), 1.02f, 0.04f, 0.9f, 2.04f),
              trim);
  }
}

// Floors (tiles in the corridor, a carpet of its own in each room) and ceilings with lights.
void AddSlabs(FloorBuilder& build, std::uint16_t ceiling, std::uint16_t light) {
  // One texture over the whole corridor (28 tiles of 0.6 m, 4 mm a texel): a texture repeated
  // along it would make stretches metres apart look the same to place recognition.
  const std::uint16_t tiles = build.Material(TileTexture(build.rng(), {150, 160, 165}, 28, 4096));
  const FloorRect& c = kFloorCore;
  const float south = kCorridorSouthWall + kFloorWallHalf,
              north = kCorridorNorthWall - kFloorWallHalf;
  const std::array<FloorRect, 4> corridor{
      {{0, south, 16, c.y0}, {0, c.y1, 16, north}, {0, c.y0, c.x0, c.y1}, {c.x1, c.y0, 16, c.y1}}};
  for (size_t k = 0; k < corridor.size(); ++k) {
    build.Slab("corridor_floor_" + std::to_string(k), corridor[k], 0.0f, tiles, 16.8f);
    build.Slab("corridor_ceiling_" + std::to_string(k), corridor[k], kH, ceiling, 1.5f);
  }
  for (float x = 1.0f; x < 16.0f; x += 3.0f) {
    for (float y : {(south + c.y0) / 2, (c.y1 + north) / 2}) {
      build.Add("corridor_light", Box(x, y, kH - 0.02f, 0.6f, 0.3f, 0.04f), light);
    }
  }
  for (const FloorRoom& room : FloorRooms()) {
    const cv::Scalar tone = RandomColor(build.rng(), 50, 140);
    // A carpet over the whole room (4 mm a texel), not a repeated square metre.
    const std::uint16_t carpet =
        build.Material(NoiseTexture(build.rng(), tone, 18.0, 2048, 128, 16.0));
    build.Slab(std::string(room.name) + "_floor", room.inside, 0.0f, carpet, 8.0f);
    build.Slab(std::string(room.name) + "_ceiling", room.inside, kH, ceiling, 1.5f);
    const float y = (room.inside.y0 + room.inside.y1) / 2;
    for (float x : {room.inside.x0 + 2.5f, room.inside.x1 - 2.5f}) {
      build.Add(std::string(room.name) + "_light", Box(x, y, kH - 0.02f, 0.6f, 0.6f, 0.04f), light);
    }
  }
}

// Shelves of `width` against a wall at (x, y) facing `yaw` (0: facing +y), filled with books.
void AddBookcase(FloorBuilder& build, const std::string& name, float x, float y, float yaw,
                 float width) {
  TriangleMesh shelf = Box(-width / 2, 0, 0.95f, 0.03f, 0.34f, 1.9f);
  shelf.Append(Box(width / 2, 0, 0.95f, 0.03f, 0.34f, 1.9f));
  for (int board = 0; board < 5; ++board) {
    shelf.Append(Box(0, 0, 0.05f + 0.45f * static_cast<float>(board), width, 0.34f, 0.03f));
  }
  TriangleMesh books;
  for (int board = 0; board < 4; ++board) {
    float along = -width / 2 + 0.04f;
    while (along < width / 2 - 0.1f) {
      const float thickness = static_cast<float>(build.rng().uniform(0.03, 0.08));
      const float height = static_cast<float>(build.rng().uniform(0.22, 0.38));
      books.Append(Box(along + thickness / 2, 0.03f,
                       0.065f + 0.45f * static_cast<float>(board) + height / 2, thickness * 0.95f,
                       0.24f, height, 0.2f));
      along += thickness + static_cast<float>(build.rng().uniform(0.0, 0.04));
    }
  }
  const Eigen::Isometry3f place = Translation(x, y, 0) * RotationZ(yaw);
  TriangleMesh placed_shelf, placed_books;
  placed_shelf.Append(shelf, place);
  placed_books.Append(books, place);
  build.Add(name, placed_shelf, kWood);
  const int color = build.rng().uniform(0, kBookCount);
  build.Add(name + "_books", placed_books, static_cast<std::uint16_t>(kBookFirst + color));
}

// Room A, the office: two desks with screens against the south wall, a cabinet, a plant.
void FurnishOffice(FloorBuilder& build) {
  for (float x : {1.3f, 3.5f}) {
    const std::string desk = "office_desk_" + std::to_string(static_cast<int>(x));
    build.Add(desk, Table(x, 0.42f, 1.6f, 0.75f, 0.74f), kWood);
    build.Add(desk + "_screen_case", Box(x, 0.25f, 1.05f, 0.6f, 0.05f, 0.38f), kPlastic);
    build.Add(desk + "_screen", MakeQuad({x - 0.28f, 0.28f, 1.22f}, {0.56f, 0, 0}, {0, 0, -0.34f}),
              kScreen);
    build.Add(desk + "_chair", Chair(x, 0.85f, kPi), kMetal);
  }
  build.Add("office_cabinet", Box(0.3f, 2.6f, 0.6f, 0.5f, 1.2f, 1.2f), kDarkWood);
  build.Add("office_boxes", Box(0.3f, 2.45f, 1.33f, 0.4f, 0.4f, 0.26f), kBookFirst + 7);
  TriangleMesh plant = Box(7.5f, 0.45f, 0.2f, 0.35f, 0.35f, 0.4f);
  plant.Append(MakeEllipsoid({0.35f, 0.35f, 0.5f}),
               Eigen::Isometry3f(Eigen::Translation3f(7.5f, 0.45f, 0.85f)));
  build.Add("office_plant", plant, kBookFirst + 3);
  build.Add("office_printer", Box(5.2f, 0.35f, 0.45f, 0.6f, 0.5f, 0.9f), kPlastic);
}

// Room B, the library: bookcases along the south and east walls, a reading table.
void FurnishLibrary(FloorBuilder& build) {
  for (int k = 0; k < 4; ++k) {
    AddBookcase(build, "library_shelf_" + std::to_string(k), 9.2f + 1.3f * static_cast<float>(k),
                0.2f, 0.0f, 1.2f);
  }
  AddBookcase(build, "library_shelf_east_0", 15.8f, 1.3f, kPi / 2, 1.2f);
  AddBookcase(build, "library_shelf_east_1", 15.8f, 2.6f, kPi / 2, 1.2f);
  build.Add("library_table", Table(12.5f, 3.45f, 1.8f, 0.7f, 0.74f), kDarkWood);
  build.Add("library_chair", Chair(13.7f, 3.45f, kPi / 2), kMetal);
  build.Add("library_armchair", Box(14.9f, 3.5f, 0.35f, 0.8f, 0.7f, 0.7f), kBookFirst + 1);
}

// Room C, the meeting room: a table in the middle with a chair at each end, a whiteboard, a screen
// and a sideboard.
void FurnishMeeting(FloorBuilder& build) {
  build.Add("meeting_table", Table(12.0f, 12.0f, 2.4f, 0.6f, 0.74f), kWood);
  build.Add("meeting_chair_west", Chair(10.45f, 12.0f, -kPi / 2), kMetal);
  build.Add("meeting_chair_east", Chair(13.55f, 12.0f, kPi / 2), kMetal);
  build.Add("meeting_whiteboard", MakeQuad({12.5f, 13.98f, 2.0f}, {-2.0f, 0, 0}, {0, 0, -1.1f}),
            build.Material(WhiteboardTexture(build.rng())));
  build.Add("meeting_screen_case", Box(15.97f, 12.0f, 1.5f, 0.05f, 1.3f, 0.75f), kPlastic);
  build.Add("meeting_screen", MakeQuad({15.94f, 11.4f, 1.82f}, {0, 1.2f, 0}, {0, 0, -0.64f}),
            kScreen);
  build.Add("meeting_sideboard", Box(8.5f, 12.0f, 0.45f, 0.45f, 1.6f, 0.9f), kDarkWood);
}

// Room D, the kitchen: a counter along the north wall, a fridge, a small table, stacked boxes.
void FurnishKitchen(FloorBuilder& build) {
  build.Add("kitchen_counter", Box(3.5f, 13.65f, 0.45f, 4.0f, 0.6f, 0.9f), kDarkWood);
  build.Add("kitchen_worktop", Box(3.5f, 13.63f, 0.92f, 4.04f, 0.66f, 0.04f), kMetal);
  build.Add("kitchen_cupboards", Box(3.5f, 13.8f, 1.9f, 4.0f, 0.35f, 0.7f), kWood);
  build.Add("kitchen_fridge", Box(0.4f, 12.3f, 0.9f, 0.7f, 0.7f, 1.8f), kMetal);
  build.Add("kitchen_table", Table(7.3f, 13.1f, 0.8f, 0.8f, 0.74f), kWood);
  build.Add("kitchen_chair", Chair(7.3f, 12.45f, 0.0f), kMetal);
  TriangleMesh boxes = Box(7.5f, 10.5f, 0.2f, 0.5f, 0.4f, 0.4f);
  boxes.Append(Box(7.45f, 10.5f, 0.6f, 0.45f, 0.38f, 0.4f));
  boxes.Append(Box(7.5f, 11.0f, 0.2f, 0.5f, 0.5f, 0.4f));
  build.Add("kitchen_boxes", boxes, kBookFirst + 6);
}

// Corridor details: a notice board and a fire extinguisher on the blank core, a bench.
void AddCorridorDetails(FloorBuilder& build) {
  build.Add("notice_board", MakeQuad({10.0f, 5.59f, 1.7f}, {-1.0f, 0, 0}, {0, 0, -0.7f}),
            build.Material(WallTexture(build.rng(), {120, 140, 160})));
  build.Add("extinguisher", Box(14.47f, 7.0f, 0.45f, 0.14f, 0.14f, 0.5f), kBookFirst + 2);
  build.Add("bench", Box(4.5f, 8.6f, 0.22f, 1.4f, 0.35f, 0.44f), kWood);
}

// Eight people: walkers along each corridor, passing the camera at about 0.4 m, people crossing
// the rooms, one sitting at a desk and one who walks to the kitchen counter, stands there for
// 40 s and leaves.
void AddFloorPeople(cv::RNG& rng, Scene* scene) {
  PeopleAdder add(scene, rng);
  add.Walker({1.0f, 5.25f}, {15.0f, 5.25f}, 1.0f, 4.0f);
  add.Walker({15.0f, 9.6f}, {1.0f, 9.6f}, 0.9f, 9.0f);
  add.Walker({15.6f, 4.7f}, {15.6f, 9.4f}, 0.8f, 2.0f);
  add.Walker({0.4f, 9.4f}, {0.4f, 4.7f}, 0.8f, 6.0f);
  add.Walker({2.0f, 3.4f}, {5.6f, 3.4f}, 0.7f);
  add.Sitter({1.3f, 0.87f, 0.5f}, kPi, 1.0f);
  // At the kitchen counter while the camera goes along it (197-209 s), then back.
  MovingObject& waiting = add.Walker({5.5f, 13.05f}, {2.5f, 13.05f}, 0.9f);
  waiting.motion = Motion::kStopAndGo;
  waiting.wait_s = 186.0f;
  waiting.stand_s = 40.0f;
  add.Walker({1.5f, 11.0f}, {5.5f, 12.8f}, 0.8f, 3.0f);
}

}  // namespace

void AddFloor(cv::RNG& rng, Scene* scene) {
  scene->first_dynamic_id = 1000;
  FloorBuilder build(rng, scene);
  const std::uint16_t corridor_paint = build.Material(PlainPaint(rng, {205, 212, 215}));
  const std::uint16_t core_paint = build.Material(PlainPaint(rng, {190, 200, 205}));
  const std::uint16_t trim = build.Material(WoodTexture(rng, {60, 85, 110}));
  const std::uint16_t light = build.Material(PlainPaint(rng, {250, 250, 250}));
  AddWalls(build, corridor_paint, core_paint, trim);
  AddSlabs(build, kCeiling, light);
  FurnishOffice(build);
  FurnishLibrary(build);
  FurnishMeeting(build);
  FurnishKitchen(build);
  AddCorridorDetails(build);
  AddFloorPeople(rng, scene);
}

}  // namespace stillmap::synth
