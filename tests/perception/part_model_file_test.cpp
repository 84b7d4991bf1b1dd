// Prepared parts kept between runs (part_model_file.hpp): a model read back is the model built, field for
// field and answer for answer; the key tells apart every input the model is made of; a file of another key,
// cut short, altered or lengthened is refused and leaves the model alone; a run that reads the part answers
// as the run that built it, and a folder that cannot be written only means the part is built.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "perception/localize/part_model_file.hpp"
#include "perception/localizer.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("weldtwin_part_model_file_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The tube on its plate: thin walls, a footprint, an outline and faces continued past its edges.
Mesh tube_mesh() {
  return load_mesh(test::repo("scenes/parts/tube_on_plate.stl"));
}

// The tube's mesh at rest and its model built as the localizer builds it.
struct Built {
  Mesh mesh = tube_mesh();
  Mesh rest = resting_mesh(mesh, 0.0);
  PartModel model;
  explicit Built(const PartModelSetting& setting = {}) { build_part_model_at_rest(rest, setting, 0, model); }
};

std::vector<char> bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(in), {});
}
void write_bytes(const fs::path& p, const std::vector<char>& b) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(b.data(), static_cast<std::streamsize>(b.size()));
}

template <class V>
bool same(const std::vector<V>& a, const std::vector<V>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!(a[i] == b[i])) return false;
  return true;
}

TEST(PartModelFile, AModelReadBackIsTheModelBuilt) {
  const PartModelSetting setting;
  Built made(setting);
  const Mesh &mesh = made.mesh, &rest = made.rest;
  PartModel& built = made.model;
  const uint64_t key = part_model_key(mesh, 0.0, setting);
  ASSERT_NE(key, 0u) << "the test program has no build id";
  const std::string path = part_model_path(fresh_dir("roundtrip").string(), key);
  ASSERT_EQ(save_part_model(built, rest, key, path), "");

  PartModel read;
  Mesh read_rest;
  ASSERT_EQ(load_part_model(path, key, read, read_rest), PartFileRead::kRead);
  make_lookups(read_rest, setting, read);
  EXPECT_TRUE(same(read_rest.vertices, rest.vertices));
  EXPECT_TRUE(same(read_rest.faces, rest.faces));
  EXPECT_TRUE(same(read.pts, built.pts));
  EXPECT_TRUE(same(read.nrm, built.nrm));
  EXPECT_TRUE(same(read.visible, built.visible));
  EXPECT_TRUE(same(read.view_score, built.view_score));
  EXPECT_TRUE(same(read.view_mask, built.view_mask));
  EXPECT_EQ(read.view_total, built.view_total);  // recomputed from the masks and normals read
  EXPECT_TRUE(same(read.half_thickness, built.half_thickness));
  EXPECT_TRUE(same(read.edge_distance, built.edge_distance));
  EXPECT_EQ(read.lo, built.lo);
  EXPECT_EQ(read.hi, built.hi);
  EXPECT_EQ(read.radius, built.radius);
  EXPECT_EQ(read.height, built.height);
  EXPECT_EQ(read.spacing_m, built.spacing_m);
  EXPECT_EQ(read.height_bin_m, built.height_bin_m);
  EXPECT_EQ(read.walls_by_height, built.walls_by_height);
  EXPECT_EQ(read.footprint.cell, built.footprint.cell);
  EXPECT_EQ(read.footprint.origin, built.footprint.origin);
  EXPECT_EQ(read.footprint.nx, built.footprint.nx);
  EXPECT_EQ(read.footprint.ny, built.footprint.ny);
  EXPECT_EQ(read.footprint.on, built.footprint.on);
  EXPECT_EQ(read.footprint.value, built.footprint.value);
  ASSERT_EQ(read.outline.size(), built.outline.size());
  for (size_t i = 0; i < read.outline.size(); ++i) {
    EXPECT_EQ(read.outline[i].at, built.outline[i].at);
    EXPECT_EQ(read.outline[i].out, built.outline[i].out);
    EXPECT_EQ(read.outline[i].top, built.outline[i].top);
  }
  EXPECT_EQ(read.thin_wall_m, built.thin_wall_m);
  EXPECT_TRUE(same(read.wall_side_shifts, built.wall_side_shifts));
  EXPECT_TRUE(same(read.beyond, built.beyond));
  EXPECT_TRUE(same(read.beyond_dist, built.beyond_dist));
  EXPECT_TRUE(same(read.beyond_line, built.beyond_line));
  EXPECT_TRUE(same(read.beyond_line_length, built.beyond_line_length));
  EXPECT_EQ(read.cx, built.cx);
  EXPECT_EQ(read.cy, built.cy);
  EXPECT_EQ(read.cz, built.cz);
  EXPECT_EQ(read.cache_origin, built.cache_origin);
  // The lookups made afresh answer as the built ones: nearest samples, rays, nearest surface points.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 3000; ++i) {
    const Vec3 q = built.lo +
                   (built.hi - built.lo + Vec3::Constant(0.02)).cwiseProduct(Vec3(u(rng), u(rng), u(rng))) -
                   Vec3::Constant(0.01);
    ASSERT_EQ(read.nearest(q), built.nearest(q)) << q.transpose();
    ASSERT_EQ(read.rays->hit(q, -Vec3::UnitZ(), 0.0), built.rays->hit(q, -Vec3::UnitZ(), 0.0));
    Vec3 pa, na, pb, nb;
    const bool a = read.surface->closest(q, 0.01, pa, na), b = built.surface->closest(q, 0.01, pb, nb);
    ASSERT_EQ(a, b);
    if (a) {
      ASSERT_EQ(pa, pb);
    }
  }
}

TEST(PartModelFile, TheKeyTellsApartEverythingTheModelIsMadeOf) {
  const Mesh mesh = tube_mesh();
  const PartModelSetting base;
  const uint64_t key = part_model_key(mesh, 0.0, base);
  EXPECT_EQ(part_model_key(tube_mesh(), 0.0, PartModelSetting()), key);  // the same input, the same key
  Mesh moved = mesh;
  moved.vertices[moved.vertices.size() / 2].x() += 1e-6;  // one vertex a micrometre away
  EXPECT_NE(part_model_key(moved, 0.0, base), key);
  Mesh turned = mesh;
  std::swap(turned.faces[0][1], turned.faces[0][2]);  // one face wound the other way
  EXPECT_NE(part_model_key(turned, 0.0, base), key);
  EXPECT_NE(part_model_key(mesh, 1e-9, base), key);  // lifted otherwise
  std::vector<PartModelSetting> changed(10, base);
  changed[0].spacing_m = 0.0021;
  changed[1].edge_reach_m = 0.04;
  changed[2].lookup_margin_m = 0.016;
  changed[3].wall_directions = 3;
  changed[4].beyond_m.push_back(0.03);
  changed[5].beyond_m[1] = 0.011;
  changed[6].closest.cell_m = 0.003;
  changed[7].closest.max_cells = 1 << 20;
  changed[8].beyond_clearance_share = 0.6;
  changed[9].beyond_up_min_z = 0.8;
  for (size_t i = 0; i < changed.size(); ++i) EXPECT_NE(part_model_key(mesh, 0.0, changed[i]), key) << i;
}

TEST(PartModelFile, AnotherKeyOrADamagedFileIsRefusedAndLeavesTheModelAlone) {
  const PartModelSetting setting;
  const Built b(setting);
  const Mesh &mesh = b.mesh, &rest = b.rest;
  const PartModel& built = b.model;
  const uint64_t key = part_model_key(mesh, 0.0, setting);
  const fs::path dir = fresh_dir("damaged");
  const std::string path = part_model_path(dir.string(), key);
  ASSERT_EQ(save_part_model(built, rest, key, path), "");
  const std::vector<char> good = bytes_of(path);
  ASSERT_GT(good.size(), 1000u);

  auto read_as = [&](const std::vector<char>& bytes, uint64_t k) {
    const fs::path p = dir / "probe.part";
    write_bytes(p, bytes);
    PartModel m;
    m.radius = 123.0;  // untouched unless read
    Mesh r;
    const PartFileRead got = load_part_model(p.string(), k, m, r);
    if (got != PartFileRead::kRead) {
      EXPECT_TRUE(m.radius == 123.0 && m.pts.empty() && r.vertices.empty());
    }
    return got;
  };
  EXPECT_EQ(read_as(good, key), PartFileRead::kRead);
  EXPECT_EQ(read_as(good, key ^ 1), PartFileRead::kOtherKey);
  PartModel untouched;
  Mesh none;
  EXPECT_EQ(load_part_model((dir / "absent.part").string(), key, untouched, none), PartFileRead::kMissing);
  // Cut short anywhere, one byte altered anywhere, a byte too many: damaged.
  for (size_t cut :
       {size_t{0}, size_t{7}, size_t{24}, size_t{25}, good.size() / 3, good.size() - 9, good.size() - 1})
    EXPECT_EQ(read_as(std::vector<char>(good.begin(), good.begin() + static_cast<long>(cut)), key),
              PartFileRead::kDamaged)
        << cut;
  std::mt19937_64 rng(3);
  for (int i = 0; i < 40; ++i) {
    std::vector<char> bad = good;
    const size_t at = 24 + rng() % (good.size() - 24);  // past the header: the checksum must notice
    bad[at] = static_cast<char>(bad[at] ^ (1 << (rng() % 8)));
    EXPECT_EQ(read_as(bad, key), PartFileRead::kDamaged) << at;
  }
  std::vector<char> longer = good;
  longer.push_back(0);
  EXPECT_EQ(read_as(longer, key), PartFileRead::kDamaged);
  // A body whose counts claim more than it holds (2^61 vertices: the count times 8 bytes wraps to 0) is
  // refused without allocating for them (found by fuzz_part_file).
  const unsigned char wraps[16] = {0, 0, 0, 0, 0, 0, 0, 0x60, 0, 0, 0, 0, 0, 0, 0xb7, 0x08};
  PartModel m;
  Mesh r;
  EXPECT_FALSE(read_part_model_body(reinterpret_cast<const char*>(wraps), sizeof wraps, m, r));
  // A header that claims more than the file holds is refused before anything is allocated for it.
  std::vector<char> claims = good;
  const uint64_t huge = uint64_t{1} << 40;
  std::memcpy(claims.data() + 16, &huge, sizeof huge);
  EXPECT_EQ(read_as(claims, key), PartFileRead::kDamaged);
}

TEST(PartModelFile, TheLookupsReadBackAnswerAsTheyWereAskedAndNothingElseGetsIn) {
  const Mesh mesh = tube_mesh();
  const PartModelSetting setting;
  const Mesh rest = resting_mesh(mesh, 0.0);
  PartModel asked;
  build_part_model_at_rest(rest, setting, 0, asked);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> qs;
  for (int i = 0; i < 4000; ++i)
    qs.push_back(asked.lo + (asked.hi - asked.lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng))));
  std::vector<int> answers;
  for (const Vec3& q : qs) {
    answers.push_back(asked.nearest(q));
    Vec3 point, normal;
    asked.surface->closest(q, 0.01, point, normal);
  }
  ASSERT_GT(asked.surface->cells_made(), 100u);
  const fs::path dir = fresh_dir("lookups");
  const std::string path = part_lookups_path(part_model_path(dir.string(), 42));
  EXPECT_EQ(fs::path(path).extension(), ".lookup");
  ASSERT_EQ(save_part_lookups(asked, 42, path), "");

  // Read into a fresh model: the bricks and cells asked about are there, the bricks with the answers the
  // asking gave, and every answer (those and any other, nearest samples and closest faces) is the one a
  // model that was never read gives.
  PartModel fresh;
  build_part_model_at_rest(rest, setting, 0, fresh);
  ASSERT_EQ(load_part_lookups(path, 42, fresh, rest.faces.size()), PartFileRead::kRead);
  EXPECT_EQ(fresh.cache.bricks_made(), asked.cache.bricks_made());
  EXPECT_EQ(fresh.surface->cells_made(), asked.surface->cells_made());
  PartModel never;
  build_part_model_at_rest(rest, setting, 0, never);
  for (size_t i = 0; i < qs.size(); ++i) {
    const Vec3& q = qs[i];
    const long ix = static_cast<long>((q.x() - fresh.cache_origin.x()) / fresh.cache_cell),
               iy = static_cast<long>((q.y() - fresh.cache_origin.y()) / fresh.cache_cell),
               iz = static_cast<long>((q.z() - fresh.cache_origin.z()) / fresh.cache_cell);
    ASSERT_EQ(*fresh.cache.slot(ix, iy, iz), answers[i] + 2);  // read, not asked again
    ASSERT_EQ(fresh.nearest(q), answers[i]);
    ASSERT_EQ(never.nearest(q), answers[i]);
    const Vec3 other = q + Vec3(0.0037, -0.0021, 0.0013);
    ASSERT_EQ(fresh.nearest(other), never.nearest(other));
    for (const Vec3& at : {q, other}) {
      Vec3 pa, na, pb, nb;
      const bool a = fresh.surface->closest(at, 0.01, pa, na), b = never.surface->closest(at, 0.01, pb, nb);
      ASSERT_EQ(a, b);
      if (a) {
        ASSERT_EQ(pa, pb);
        ASSERT_EQ(na, nb);
      }
    }
  }
  EXPECT_EQ(fresh.surface->cells_made(), never.surface->cells_made());  // none asked anew: all were read

  // Another key, a damaged file, another grid's file, an answer no sample has: refused, the grid untouched.
  auto refused = [&](const std::string& p, uint64_t key) {
    PartModel m;
    build_part_model_at_rest(rest, setting, 0, m);
    const PartFileRead got = load_part_lookups(p, key, m, rest.faces.size());
    EXPECT_EQ(m.cache.bricks_made(), 0u);
    EXPECT_EQ(m.surface->cells_made(), 0u);
    return got;
  };
  EXPECT_EQ(refused(path, 43), PartFileRead::kOtherKey);
  std::vector<char> bytes = bytes_of(path);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 4);
  write_bytes(dir / "damaged.lookup", bytes);
  EXPECT_EQ(refused((dir / "damaged.lookup").string(), 42), PartFileRead::kDamaged);
  PartModelSetting finer = setting;
  finer.lookup_cell_m = 0.0008;
  PartModel other_grid;
  build_part_model_at_rest(rest, finer, 0, other_grid);
  other_grid.nearest(qs[0]);
  ASSERT_EQ(save_part_lookups(other_grid, 42, (dir / "other_grid.lookup").string()), "");
  EXPECT_EQ(refused((dir / "other_grid.lookup").string(), 42), PartFileRead::kDamaged);
  PartModel wrong;
  build_part_model_at_rest(rest, setting, 0, wrong);
  *wrong.cache.slot(3, 3, 3) = static_cast<int>(wrong.pts.size()) + 2;  // the answer n: no such sample
  ASSERT_EQ(save_part_lookups(wrong, 42, (dir / "wrong.lookup").string()), "");
  EXPECT_EQ(refused((dir / "wrong.lookup").string(), 42), PartFileRead::kDamaged);
  PartModel no_face;  // a cell naming a face the mesh does not have
  build_part_model_at_rest(rest, setting, 0, no_face);
  no_face.surface->put_cell(5, {0.01, {static_cast<unsigned>(rest.faces.size())}, {0.01}});
  ASSERT_EQ(save_part_lookups(no_face, 42, (dir / "no_face.lookup").string()), "");
  EXPECT_EQ(refused((dir / "no_face.lookup").string(), 42), PartFileRead::kDamaged);
}

TEST(PartModelFile, OnlyTheNewestFilesAreKept) {
  const Built b;
  const Mesh& rest = b.rest;
  const PartModel& built = b.model;
  const fs::path dir = fresh_dir("prune");
  const auto now = fs::file_time_type::clock::now();
  for (uint64_t k = 1; k <= 5; ++k) {
    ASSERT_EQ(save_part_model(built, rest, k, part_model_path(dir.string(), k), 3), "");
    fs::last_write_time(part_model_path(dir.string(), k), now - std::chrono::hours(10 - k));
  }
  write_bytes(dir / "notes.txt", {'x'});  // not a model file: left alone
  ASSERT_EQ(save_part_model(built, rest, 6, part_model_path(dir.string(), 6), 3), "");
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename().string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"0000000000000004.part", "0000000000000005.part",
                                            "0000000000000006.part", "notes.txt"}));
}

TEST(PartModelFile, ARunThatReadsThePartAnswersAsTheRunThatBuiltIt) {
  const test::TwinScan scan = test::twin_scan("scenes/cells/default.yaml", 5);
  const Mesh mesh = load_mesh(scan.part.mesh_path);
  const std::vector<Vec3> seams = scan.part.seam_points(0.001);
  const fs::path dir = fresh_dir("runs");
  const PoseEstimate off =
      localize(scan.cloud, PreparedPart(mesh), LocalizeSetting(), seams, scan.viewpoints);
  const PoseEstimate first = localize(scan.cloud, PreparedPart(mesh, LocalizeSetting(), true, dir.string()),
                                      LocalizeSetting(), seams, scan.viewpoints);
  const PreparedPart reading(mesh, LocalizeSetting(), false, dir.string());
  const PoseEstimate second = localize(scan.cloud, reading, LocalizeSetting(), seams, scan.viewpoints);
  // Its lookups kept, a third run starts with them and answers the same.
  EXPECT_EQ(reading.keep_lookups(), "");
  const std::string lookups =
      part_lookups_path(part_model_path(dir.string(), part_model_key(mesh, 0.0, LocalizeSetting().model)));
  EXPECT_TRUE(fs::exists(lookups));
  const PoseEstimate third = localize(scan.cloud, PreparedPart(mesh, LocalizeSetting(), false, dir.string()),
                                      LocalizeSetting(), seams, scan.viewpoints);
  EXPECT_EQ(third.part_file, "read");
  EXPECT_EQ(off.part_file, "off");
  EXPECT_EQ(first.part_file, "written");
  EXPECT_EQ(second.part_file, "read");
  ASSERT_TRUE(off.found) << off.reason;
  for (const PoseEstimate* p : {&first, &second, &third}) {
    EXPECT_EQ(p->found, off.found);
    EXPECT_TRUE(p->T_base_part.matrix() == off.T_base_part.matrix());
    EXPECT_EQ(p->fitness, off.fitness);
    EXPECT_EQ(p->coverage, off.coverage);
    EXPECT_EQ(p->seam_error_bound_m, off.seam_error_bound_m);
  }
  // A damaged file is built again (and written anew); a folder that cannot be made is only a note.
  const std::string path = part_model_path(dir.string(), part_model_key(mesh, 0.0, LocalizeSetting().model));
  std::vector<char> bytes = bytes_of(path);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
  write_bytes(path, bytes);
  const PoseEstimate rebuilt =
      localize(scan.cloud, PreparedPart(mesh, LocalizeSetting(), false, dir.string()), LocalizeSetting(),
               seams, scan.viewpoints);
  EXPECT_EQ(rebuilt.part_file, "written");
  EXPECT_TRUE(rebuilt.T_base_part.matrix() == off.T_base_part.matrix());
  write_bytes(dir / "a_file", {'x'});
  const PoseEstimate unkept =
      localize(scan.cloud, PreparedPart(mesh, LocalizeSetting(), false, (dir / "a_file" / "parts").string()),
               LocalizeSetting(), seams, scan.viewpoints);
  EXPECT_EQ(unkept.part_file.rfind("not written: ", 0), 0u) << unkept.part_file;
  EXPECT_TRUE(unkept.T_base_part.matrix() == off.T_base_part.matrix());
}

}  // namespace
}  // namespace weldtwin
