// A part spec's height, outline and clamp sites taken from its mesh: on meshes built here (boxes), and on a
// shipped part whose spec gives all three by hand.
#include "core/part_outline.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "core/error.hpp"
#include "tests/input_error_of.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

using Vec2 = Eigen::Vector2d;

// Appends an axis-aligned box (12 triangles, outward) to `mesh`.
void add_box(Mesh& mesh, const Vec3& lo, const Vec3& hi) {
  const int base = static_cast<int>(mesh.vertices.size());
  for (int i = 0; i < 8; ++i)
    mesh.vertices.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh.faces.emplace_back(base + q[0], base + q[1], base + q[2]);
    mesh.faces.emplace_back(base + q[0], base + q[2], base + q[3]);
  }
}

// A 160 mm square plate, 8 mm thick, with a 50 mm square post 108 mm tall at its centre.
Mesh plate_with_post() {
  Mesh m;
  add_box(m, Vec3(-0.08, -0.08, 0), Vec3(0.08, 0.08, 0.008));
  add_box(m, Vec3(-0.025, -0.025, 0), Vec3(0.025, 0.025, 0.108));
  return m;
}

// The four fillet seams around the post's foot.
std::vector<Seam> seams_around_post() {
  std::vector<Seam> seams;
  const double h = 0.025, z = 0.008;
  const Vec3 c[4] = {{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}};
  for (int i = 0; i < 4; ++i) {
    Seam s;
    s.start = c[i];
    s.end = c[(i + 1) % 4];
    seams.push_back(s);
  }
  return seams;
}

double signed_area(const std::vector<Vec2>& p) {
  double a = 0;
  for (size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) a += p[j].x() * p[i].y() - p[i].x() * p[j].y();
  return 0.5 * a;
}

bool holds_point(const std::vector<Vec2>& pts, const Vec2& q, double tol) {
  for (const Vec2& p : pts)
    if ((p - q).norm() < tol) return true;
  return false;
}

std::string write_file(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_part_outline_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

std::string ascii_stl(const Mesh& m) {
  std::ostringstream os;
  os << "solid m\n";
  for (const auto& f : m.faces) {
    os << "facet normal 0 0 0\nouter loop\n";
    for (int k = 0; k < 3; ++k) {
      const Vec3& v = m.vertices[static_cast<size_t>(f[k])];
      os << "vertex " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    }
    os << "endloop\nendfacet\n";
  }
  os << "endsolid m\n";
  return os.str();
}

using test::input_error_of;

const char* kSeam =
    "seams:\n  - name: front\n    start: [-0.025, -0.025, 0.008]\n    end: [0.025, -0.025, 0.008]\n"
    "    normal: [0, 0, 1]\n    wall_normal: [0, -1, 0]\n    work_angle_deg: 45\n    travel_angle_deg: 0\n"
    "    torch_roll_deg: free\n    speed_mm_s: 8\n";

TEST(PartOutline, ConvexOutlineOfATeeIsItsSixCornersCounterClockwise) {
  Mesh tee;  // a bar lying along x and a stem along +y, seen from above a T
  add_box(tee, Vec3(-0.15, -0.05, 0), Vec3(0.15, 0.05, 0.05));
  add_box(tee, Vec3(-0.03, 0.05, 0), Vec3(0.03, 0.21, 0.05));
  const std::vector<Vec2> hull = convex_outline(tee);
  ASSERT_EQ(hull.size(), 6u);
  EXPECT_GT(signed_area(hull), 0.0);
  for (const Vec2& corner : {Vec2(-0.15, -0.05), Vec2(0.15, -0.05), Vec2(0.15, 0.05), Vec2(0.03, 0.21),
                             Vec2(-0.03, 0.21), Vec2(-0.15, 0.05)})
    EXPECT_TRUE(holds_point(hull, corner, 1e-12)) << corner.transpose();
  // Area of the T's hull: the bar, the stem, and the two triangles between them.
  EXPECT_NEAR(signed_area(hull), 0.3 * 0.1 + 0.06 * 0.16 + 2 * 0.5 * 0.12 * 0.16, 1e-12);
}

TEST(PartOutline, SurfaceAboveIsTheHighestFaceOrNothing) {
  const Mesh m = plate_with_post();
  const auto plate = surface_above(m, Vec2(0.06, 0.05));
  ASSERT_TRUE(plate);
  EXPECT_NEAR(plate->z_m, 0.008, 1e-12);
  EXPECT_NEAR(plate->normal.z(), 1.0, 1e-12);
  const auto post = surface_above(m, Vec2(0.01, -0.02));
  ASSERT_TRUE(post);
  EXPECT_NEAR(post->z_m, 0.108, 1e-12);
  EXPECT_FALSE(surface_above(m, Vec2(0.09, 0.0)));
  const MeshBox box = mesh_box(m);
  EXPECT_EQ(box.lo.z(), 0.0);
  EXPECT_EQ(box.hi.z(), 0.108);
}

TEST(PartOutline, ClampSitesSitOnThePlateInsideItsCornersAndEdgesPointingOut) {
  const Mesh m = plate_with_post();
  const std::vector<ClampSite> sites = outline_clamp_sites(m, convex_outline(m), seams_around_post());
  ASSERT_EQ(sites.size(), 8u);  // four corners, four edge middles
  for (const ClampSite& s : sites) {
    EXPECT_NEAR(s.grip.z(), 0.008, 1e-12);
    EXPECT_NEAR(s.grip.head<2>().cwiseAbs().maxCoeff(), 0.08 - 0.012, 1e-9) << s.grip.transpose();
    EXPECT_NEAR(s.outward.norm(), 1.0, 1e-12);
    EXPECT_GT(s.outward.dot(s.grip.head<2>().normalized()), 0.99) << "towards the clamp, away from the part";
  }
  // A seam along one edge takes that edge's sites away (a clamp there would stand in the torch's way).
  std::vector<Seam> seams = seams_around_post();
  Seam edge;
  edge.start = Vec3(-0.07, -0.075, 0.008);
  edge.end = Vec3(0.07, -0.075, 0.008);
  seams.push_back(edge);
  const std::vector<ClampSite> fewer = outline_clamp_sites(m, convex_outline(m), seams);
  EXPECT_EQ(fewer.size(), 5u);
  for (const ClampSite& s : fewer) EXPECT_GT(s.grip.y(), -0.05) << s.grip.transpose();
  // A block on one corner: the pad would not rest on one level face there.
  Mesh blocked = plate_with_post();
  add_box(blocked, Vec3(0.06, 0.06, 0), Vec3(0.08, 0.08, 0.02));
  const std::vector<ClampSite> around =
      outline_clamp_sites(blocked, convex_outline(blocked), seams_around_post());
  EXPECT_EQ(around.size(), 7u);
  for (const ClampSite& s : around)
    EXPECT_FALSE(s.grip.x() > 0.05 && s.grip.y() > 0.05) << s.grip.transpose();
}

// The shipped tube_on_plate spec gives its height, outline and clamp sites by hand; a spec with only the
// documented fields (name, model, seams) gets them from the mesh, and they agree.
TEST(PartOutline, ASpecWithOnlyTheDocumentedFieldsGetsWhatTheMeshSays) {
  const std::string stl = test::repo("scenes/parts/tube_on_plate.stl");
  const PartSpec full = PartSpec::load(test::repo("scenes/parts/tube_on_plate.yaml"));
  const std::string yaml = "name: tube_on_plate\nmodel: " + stl + "\n" + kSeam;
  const PartSpec bare = PartSpec::load(write_file("bare.yaml", yaml));
  EXPECT_NEAR(bare.height_m, full.height_m, 0.5e-3);
  ASSERT_EQ(bare.footprint.size(), full.footprint.size());
  for (const Vec2& p : full.footprint) EXPECT_TRUE(holds_point(bare.footprint, p, 1e-6)) << p.transpose();
  for (const ClampSite& given : full.clamp_sites) {
    bool matched = false;
    for (const ClampSite& s : bare.clamp_sites)
      matched |= (s.grip - given.grip).norm() < 0.004 && s.outward.dot(given.outward) > std::cos(deg2rad(5));
    EXPECT_TRUE(matched) << "no site drawn near the given " << given.grip.transpose();
  }
  // `clamp_sites:` given empty: a part held without clamps.
  EXPECT_TRUE(PartSpec::load(write_file("none.yaml", yaml + "clamp_sites:\n")).clamp_sites.empty());
}

TEST(PartOutline, AMeshOffItsBaseOrAHeightTheMeshDoesNotHaveIsRefused) {
  Mesh lifted;
  add_box(lifted, Vec3(-0.08, -0.08, 0.02), Vec3(0.08, 0.08, 0.03));
  const std::string stl = write_file("lifted.stl", ascii_stl(lifted));
  const std::string spec = write_file("lifted.yaml", "name: p\nmodel: " + stl + "\n" + kSeam);
  const std::string why = input_error_of([&] { PartSpec::load(spec); });
  EXPECT_NE(why.find("lifted.yaml"), std::string::npos) << why;
  EXPECT_NE(why.find("lowest point is at z = 20.0 mm"), std::string::npos) << why;

  const std::string tube = test::repo("scenes/parts/tube_on_plate.stl");
  const std::string tall = write_file("tall.yaml", "name: p\nmodel: " + tube + "\nheight_mm: 120\n" + kSeam);
  const std::string height = input_error_of([&] { PartSpec::load(tall); });
  EXPECT_NE(height.find("height 120.0 mm but the mesh reaches 108.0 mm"), std::string::npos) << height;
  EXPECT_NEAR(PartSpec::load(write_file("mm.yaml", "name: p\nmodel: " + tube + "\nheight_mm: 108\n" + kSeam))
                  .height_m,
              0.108, 1e-12);
}

// What the fuzzer wrote: a seam ending 2.5 km from the part (sampled every few millimetres downstream, the
// spec took seconds to load), and an arc wound twice around.
TEST(PartOutline, SeamsOffThePartOrWoundMoreThanOnceAreRefused) {
  const std::string tube = test::repo("scenes/parts/tube_on_plate.stl");
  std::string far = kSeam;
  far.replace(far.find("end: [0.025, -0.025, 0.008]"), 27, "end: [2504.0, -0.025, 0.008]");
  const std::string why =
      input_error_of([&] { PartSpec::load(write_file("far.yaml", "name: p\nmodel: " + tube + "\n" + far)); });
  EXPECT_NE(why.find("seam 'front' leaves the part"), std::string::npos) << why;
  const std::string arc =
      "seams:\n  - name: round\n    start: [0.03, 0, 0.008]\n    center: [0, 0, 0.008]\n    axis: [0, 0, 1]\n"
      "    sweep_deg: 720\n    normal: [0, 0, 1]\n    wall_normal: radial\n    work_angle_deg: 45\n"
      "    travel_angle_deg: 0\n    torch_roll_deg: free\n    speed_mm_s: 8\n";
  const std::string twice = input_error_of(
      [&] { PartSpec::load(write_file("twice.yaml", "name: p\nmodel: " + tube + "\n" + arc)); });
  EXPECT_NE(twice.find("sweep_deg must be within -360 and +360"), std::string::npos) << twice;
  std::string once = arc;
  once.replace(once.find("720"), 3, "360");
  EXPECT_EQ(PartSpec::load(write_file("once.yaml", "name: p\nmodel: " + tube + "\n" + once)).seams.size(),
            1u);
}

}  // namespace
}  // namespace weldtwin
