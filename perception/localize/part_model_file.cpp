#include "perception/localize/part_model_file.hpp"

#include <elf.h>
#include <link.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <system_error>
#include <type_traits>

#include "core/files.hpp"
#include "core/mapped_file.hpp"

namespace weldtwin {
namespace {

using Magic = char[8];
constexpr Magic kMagic = {'W', 'T', 'P', 'A', 'R', 'T', '0', '3'};        // bump the digits with the layout
constexpr Magic kLookupMagic = {'W', 'T', 'L', 'O', 'O', 'K', '0', '2'};  // ... of either file
constexpr uint64_t kFormat = 3;                                           // ... and this: it joins the key
constexpr size_t kHeaderBytes = sizeof(Magic) + 2 * sizeof(uint64_t);
constexpr uintmax_t kMaxFileBytes = uintmax_t{1} << 32;  // a larger file is not one of ours

// A 64-bit hash of bytes, eight at a time (not cryptographic: it tells a damaged file or another input
// apart).
class Hash {
 public:
  void add(const void* data, size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (; bytes >= 8; p += 8, bytes -= 8) {
      uint64_t w;
      std::memcpy(&w, p, 8);
      mix(w);
    }
    if (bytes > 0) {
      uint64_t w = 0;
      std::memcpy(&w, p, bytes);
      mix(w ^ (uint64_t{bytes} << 56));
    }
  }
  template <class T>
  void add(const T& value) {
    static_assert(std::is_arithmetic_v<T>);
    add(&value, sizeof value);
  }
  uint64_t value() const { return h_ ^ (h_ >> 31); }

 private:
  void mix(uint64_t w) {
    h_ = (h_ ^ w) * 0x9E3779B97F4A7C15ull;
    h_ ^= h_ >> 29;
  }
  uint64_t h_ = 0x243F6A8885A308D3ull;
};

// The running program's GNU build id (empty when it has none).
std::string program_build_id() {
  std::string id;
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void* out) {
        for (int i = 0; i < info->dlpi_phnum; ++i) {
          const ElfW(Phdr)& ph = info->dlpi_phdr[i];
          if (ph.p_type != PT_NOTE) continue;
          const char* p = reinterpret_cast<const char*>(info->dlpi_addr + ph.p_vaddr);
          const char* end = p + ph.p_memsz;
          while (p + sizeof(ElfW(Nhdr)) <= end) {
            ElfW(Nhdr) note;
            std::memcpy(&note, p, sizeof note);
            const char* name = p + sizeof note;
            const char* desc = name + ((note.n_namesz + 3) & ~3u);
            if (desc + note.n_descsz > end) break;
            if (note.n_type == NT_GNU_BUILD_ID && note.n_namesz == 4 && std::memcmp(name, "GNU", 4) == 0) {
              static_cast<std::string*>(out)->assign(desc, note.n_descsz);
              return 1;
            }
            p = desc + ((note.n_descsz + 3) & ~3u);
          }
        }
        return 1;  // the first object is the program itself: not found there, not found
      },
      &id);
  return id;
}

class Writer {
 public:
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const char*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof value);
  }
  template <class T>
  void put_all(const std::vector<T>& values) {  // the count, then the values as they lie in memory
    put(static_cast<uint64_t>(values.size()));
    const auto* p = reinterpret_cast<const char*>(values.data());
    bytes_.insert(bytes_.end(), p, p + values.size() * sizeof(T));
  }
  /// Room for this many more bytes (a body of megabytes grown by doubling was copied over and over).
  void reserve_more(size_t bytes) { bytes_.reserve(bytes_.size() + bytes); }
  const std::vector<char>& bytes() const { return bytes_; }

 private:
  std::vector<char> bytes_;
};

class Reader {
 public:
  Reader(const char* p, size_t n) : p_(p), end_(p + n) {}
  template <class T>
  bool get(T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (static_cast<size_t>(end_ - p_) < sizeof value) return false;
    std::memcpy(&value, p_, sizeof value);
    p_ += sizeof value;
    return true;
  }
  template <class T>
  bool get_all(std::vector<T>& values) {  // never more than the bytes that are left
    uint64_t n = 0;
    if (!get(n) || n > static_cast<size_t>(end_ - p_) / sizeof(T)) return false;
    values.resize(n);
    if (n > 0) std::memcpy(static_cast<void*>(values.data()), p_, n * sizeof(T));
    p_ += n * sizeof(T);
    return true;
  }
  /// Passes over the next `count` items of `item_bytes` each (false when fewer are left), `at` their start.
  bool skip(uint64_t count, size_t item_bytes, const char*& at) {
    if (count > static_cast<size_t>(end_ - p_) / item_bytes) return false;
    at = p_;
    p_ += count * item_bytes;
    return true;
  }
  bool done() const { return p_ == end_; }

 private:
  const char* p_;
  const char* end_;
};

// Eigen's fixed-size types are copied as their scalars (they are not trivially copyable to the standard).
template <class V>
void put_vectors(Writer& w, const std::vector<V>& vs) {
  std::vector<typename V::Scalar> flat;
  flat.reserve(vs.size() * V::SizeAtCompileTime);
  for (const V& v : vs) flat.insert(flat.end(), v.data(), v.data() + V::SizeAtCompileTime);
  w.put_all(flat);
}
template <class V>
bool get_vectors(Reader& r, std::vector<V>& vs) {
  constexpr size_t kBytes = V::SizeAtCompileTime * sizeof(typename V::Scalar);
  uint64_t scalars = 0;
  const char* at = nullptr;
  if (!r.get(scalars) || scalars % V::SizeAtCompileTime != 0 ||
      !r.skip(scalars, sizeof(typename V::Scalar), at))
    return false;
  vs.resize(scalars / V::SizeAtCompileTime);
  for (size_t i = 0; i < vs.size(); ++i) std::memcpy(vs[i].data(), at + i * kBytes, kBytes);
  return true;
}
void put_vec3(Writer& w, const Vec3& v) {
  for (int i = 0; i < 3; ++i) w.put(v[i]);
}
bool get_vec3(Reader& r, Vec3& v) {
  return r.get(v[0]) && r.get(v[1]) && r.get(v[2]);
}

std::vector<char> payload(const PartModel& m, const Mesh& rest) {
  Writer w;
  put_vectors(w, rest.vertices);
  put_vectors(w, rest.faces);
  put_vectors(w, m.pts);
  put_vectors(w, m.nrm);
  w.put_all(m.visible);
  w.put_all(m.view_score);
  w.put_all(m.view_mask);
  w.put_all(m.half_thickness);
  w.put_all(m.edge_distance);
  put_vec3(w, m.lo);
  put_vec3(w, m.hi);
  w.put(m.radius);
  w.put(m.height);
  w.put(m.spacing_m);
  w.put(m.height_bin_m);
  w.put(static_cast<uint64_t>(m.walls_by_height.size()));
  for (const std::vector<int>& bin : m.walls_by_height) w.put_all(bin);
  w.put(m.footprint.cell);
  w.put(m.footprint.origin.x());
  w.put(m.footprint.origin.y());
  w.put(m.footprint.nx);
  w.put(m.footprint.ny);
  w.put_all(m.footprint.on);
  w.put_all(m.footprint.value);
  std::vector<double> outline;
  for (const PartModel::OutlineSample& o : m.outline)
    outline.insert(outline.end(), {o.at.x(), o.at.y(), o.out.x(), o.out.y(), o.top});
  w.put_all(outline);
  w.put(m.thin_wall_m);
  put_vectors(w, m.wall_side_shifts);
  put_vectors(w, m.beyond);
  w.put_all(m.beyond_dist);
  w.put_all(m.beyond_line);
  w.put_all(m.beyond_line_length);
  return w.bytes();
}

// Reads the payload into `m` and `rest`; false when it is cut short, too long, or its fields do not fit
// together (then `m` and `rest` may hold part of it).
bool read_payload(Reader& r, PartModel& m, Mesh& rest) {
  if (!get_vectors(r, rest.vertices) || !get_vectors(r, rest.faces)) return false;
  for (const Eigen::Vector3i& f : rest.faces)
    for (int k = 0; k < 3; ++k)
      if (f[k] < 0 || static_cast<size_t>(f[k]) >= rest.vertices.size()) return false;
  if (!get_vectors(r, m.pts) || !get_vectors(r, m.nrm) || !r.get_all(m.visible) || !r.get_all(m.view_score) ||
      !r.get_all(m.view_mask) || !r.get_all(m.half_thickness) || !r.get_all(m.edge_distance))
    return false;
  const size_t n = m.pts.size();
  if (m.nrm.size() != n || m.visible.size() != n || m.view_score.size() != n || m.view_mask.size() != n ||
      m.half_thickness.size() != n || m.edge_distance.size() != n)
    return false;
  m.view_total = view_totals(m.view_mask, m.nrm);
  uint64_t bins = 0;
  if (!get_vec3(r, m.lo) || !get_vec3(r, m.hi) || !r.get(m.radius) || !r.get(m.height) ||
      !r.get(m.spacing_m) || !r.get(m.height_bin_m) || !r.get(bins))
    return false;
  if (bins > n + 2) return false;  // more bins than samples: not a model of ours
  m.walls_by_height.resize(bins);
  for (std::vector<int>& bin : m.walls_by_height) {
    if (!r.get_all(bin)) return false;
    for (int k : bin)
      if (k < 0 || static_cast<size_t>(k) >= n) return false;
  }
  Grid2& g = m.footprint;
  if (!r.get(g.cell) || !r.get(g.origin.x()) || !r.get(g.origin.y()) || !r.get(g.nx) || !r.get(g.ny) ||
      !r.get_all(g.on) || !r.get_all(g.value))
    return false;
  if (g.nx < 0 || g.ny < 0 || g.on.size() != g.cells() || g.value.size() != g.cells()) return false;
  std::vector<double> outline;
  if (!r.get_all(outline) || outline.size() % 5 != 0) return false;
  m.outline.resize(outline.size() / 5);
  for (size_t i = 0; i < m.outline.size(); ++i) {
    const double* o = &outline[5 * i];
    m.outline[i] = {Eigen::Vector2d(o[0], o[1]), Eigen::Vector2d(o[2], o[3]), o[4]};
  }
  if (!r.get(m.thin_wall_m) || !get_vectors(r, m.wall_side_shifts) || !get_vectors(r, m.beyond) ||
      !r.get_all(m.beyond_dist) || !r.get_all(m.beyond_line) || !r.get_all(m.beyond_line_length))
    return false;
  if (m.beyond_dist.size() != m.beyond.size() || m.beyond_line.size() != m.beyond.size()) return false;
  for (int line : m.beyond_line)
    if (line < -1 || line >= static_cast<int64_t>(m.beyond_line_length.size())) return false;
  return r.done();
}

// Removes the oldest files of `dir` ending in `ext` beyond `keep` (of this program's other builds, or other
// parts).
void prune(const std::filesystem::path& dir, const std::string& ext, int keep) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::vector<std::pair<fs::file_time_type, fs::path>> files;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().extension() == ext) files.emplace_back(it->last_write_time(ec), it->path());
  if (static_cast<int>(files.size()) <= keep) return;
  std::sort(files.begin(), files.end());
  for (size_t i = 0; i + static_cast<size_t>(std::max(0, keep)) < files.size(); ++i)
    fs::remove(files[i].second, ec);
}

}  // namespace

uint64_t part_model_key(const Mesh& mesh, double min_z, const PartModelSetting& s) {
  static const std::string build = program_build_id();
  if (build.empty()) return 0;
  Hash h;
  h.add(kMagic, sizeof(Magic));
  h.add(kFormat);
  h.add(build.data(), build.size());
  h.add(static_cast<uint64_t>(mesh.vertices.size()));
  for (const Vec3& v : mesh.vertices) h.add(v.data(), sizeof(Vec3));
  h.add(static_cast<uint64_t>(mesh.faces.size()));
  for (const Eigen::Vector3i& f : mesh.faces) h.add(f.data(), sizeof(Eigen::Vector3i));
  h.add(min_z);
  // Every field of the setting (a field added to PartModelSetting must join here: the size check below
  // fails until it does).
  static_assert(sizeof(PartModelSetting) ==
                    20 * sizeof(double) + 8 + sizeof(std::vector<double>) + sizeof(ClosestGridSetting),
                "PartModelSetting changed: add its new field to the key");
  static_assert(sizeof(ClosestGridSetting) == 3 * sizeof(double) + sizeof(size_t),
                "ClosestGridSetting changed: add its new field to the key");
  for (double v : {s.spacing_m,
                   s.min_normal_z,
                   s.thickness_probe_m,
                   s.sharp_edge_deg,
                   s.edge_point_step_m,
                   s.edge_reach_m,
                   s.height_bin_m,
                   s.footprint_cell_m,
                   s.footprint_margin_m,
                   s.outline_step_m,
                   s.outline_corner_m,
                   s.outline_inside_m,
                   s.lookup_cell_m,
                   s.lookup_margin_m,
                   s.thin_wall_max_m,
                   s.thin_wall_min_share,
                   s.wall_direction_gap_deg,
                   s.beyond_step_m,
                   s.beyond_clearance_share,
                   s.beyond_up_min_z,
                   s.closest.cell_m,
                   s.closest.margin_m,
                   s.closest.far_m})
    h.add(v);
  h.add(s.wall_directions);
  h.add(static_cast<uint64_t>(s.closest.max_cells));
  h.add(static_cast<uint64_t>(s.beyond_m.size()));
  for (double v : s.beyond_m) h.add(v);
  const uint64_t key = h.value();
  return key == 0 ? 1 : key;
}

std::string part_model_path(const std::string& dir, uint64_t key) {
  char name[32];
  std::snprintf(name, sizeof name, "%016llx.part", static_cast<unsigned long long>(key));
  return (std::filesystem::path(dir) / name).string();
}

namespace {

// Writes magic, key, the body's size, the body and its checksum to `path`: whole under another name, then
// renamed. Returns "" or why not.
std::string write_checked(const std::string& path, const Magic& magic, uint64_t key,
                          const std::vector<char>& body) {
  namespace fs = std::filesystem;
  Hash sum;
  sum.add(body.data(), body.size());
  const uint64_t check = sum.value(), size = body.size();
  std::error_code ec;
  const fs::path dir = fs::path(path).parent_path();
  if (!dir.empty()) fs::create_directories(dir, ec);
  if (ec) return dir.string() + ": " + ec.message();
  const std::string tmp =
      path + ".tmp" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device()());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(magic, sizeof(Magic));
    out.write(reinterpret_cast<const char*>(&key), sizeof key);
    out.write(reinterpret_cast<const char*>(&size), sizeof size);
    out.write(body.data(), static_cast<std::streamsize>(body.size()));
    out.write(reinterpret_cast<const char*>(&check), sizeof check);
    out.close();
    if (!out) {
      fs::remove(tmp, ec);
      return path + ": cannot be written";
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    const std::string why = path + ": " + ec.message();
    fs::remove(tmp, ec);
    return why;
  }
  return "";
}

// Maps what write_checked wrote with `magic` and `key`; its body is at body_at(file), body_bytes(file) long.
PartFileRead read_checked(const std::string& path, const Magic& magic, uint64_t key, MappedFile& file) {
  if (!is_file(path)) return PartFileRead::kMissing;
  if (!file.map(path)) return PartFileRead::kDamaged;
  const size_t bytes = file.size();
  if (bytes < kHeaderBytes + sizeof(uint64_t) || bytes > kMaxFileBytes) return PartFileRead::kDamaged;
  uint64_t file_key = 0, size = 0, check = 0;
  std::memcpy(&file_key, file.data() + sizeof(Magic), sizeof file_key);
  std::memcpy(&size, file.data() + sizeof(Magic) + sizeof file_key, sizeof size);
  if (std::memcmp(file.data(), magic, sizeof(Magic)) != 0 || file_key != key) return PartFileRead::kOtherKey;
  if (size != bytes - kHeaderBytes - sizeof(uint64_t)) return PartFileRead::kDamaged;
  std::memcpy(&check, file.data() + kHeaderBytes + size, sizeof check);
  Hash sum;
  sum.add(file.data() + kHeaderBytes, size);
  return sum.value() == check ? PartFileRead::kRead : PartFileRead::kDamaged;
}
const char* body_at(const MappedFile& file) {
  return file.data() + kHeaderBytes;
}
size_t body_bytes(const MappedFile& file) {
  return file.size() - kHeaderBytes - sizeof(uint64_t);
}

void prune_beside(const std::string& path, const char* ext, int keep) {
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (!dir.empty()) prune(dir, ext, keep);
}

}  // namespace

std::string save_part_model(const PartModel& model, const Mesh& rest, uint64_t key, const std::string& path,
                            int keep_files) {
  const std::string why = write_checked(path, kMagic, key, payload(model, rest));
  if (why.empty()) prune_beside(path, ".part", keep_files);
  return why;
}

PartFileRead load_part_model(const std::string& path, uint64_t key, PartModel& model, Mesh& rest) {
  MappedFile file;
  const PartFileRead got = read_checked(path, kMagic, key, file);
  if (got != PartFileRead::kRead) return got;
  return read_part_model_body(body_at(file), body_bytes(file), model, rest) ? PartFileRead::kRead
                                                                            : PartFileRead::kDamaged;
}

bool read_part_model_body(const char* data, size_t size, PartModel& model, Mesh& rest) {
  PartModel read;
  Mesh read_rest;
  Reader r(data, size);
  if (!read_payload(r, read, read_rest)) return false;
  model = std::move(read);
  rest = std::move(read_rest);
  return true;
}

std::string part_lookups_path(const std::string& part_path) {
  return std::filesystem::path(part_path).replace_extension(".lookup").string();
}

std::string save_part_lookups(const PartModel& model, uint64_t key, const std::string& path, int keep_files) {
  using Slots = BrickSlots<int>;
  Writer w;
  // The nearest-sample grid: its capacity, then every brick made (index, slots).
  const size_t capacity = model.cache.brick_capacity();
  std::vector<size_t> made;
  for (size_t b = 0; b < capacity; ++b)
    if (model.cache.brick(b)) made.push_back(b);
  const ClosestGrid* surface = model.surface.get();
  size_t cell_bytes = 0;
  if (surface)
    surface->for_each_cell([&](size_t, const ClosestGrid::Cell& c) {
      cell_bytes += 4 * sizeof(uint64_t) + c.faces.size() * (sizeof(unsigned) + sizeof(double));
    });
  w.reserve_more(4 * sizeof(uint64_t) +
                 made.size() * (2 * sizeof(uint64_t) + Slots::kBrickSlots * sizeof(int)) + cell_bytes);
  w.put(static_cast<uint64_t>(capacity));
  w.put(static_cast<uint64_t>(made.size()));
  std::vector<int> slots(Slots::kBrickSlots);
  for (size_t b : made) {
    const int* brick = model.cache.brick(b);
    for (size_t i = 0; i < Slots::kBrickSlots; ++i) slots[i] = __atomic_load_n(brick + i, __ATOMIC_RELAXED);
    w.put(static_cast<uint64_t>(b));
    w.put_all(slots);
  }
  // The closest-face grid: its size, then every cell filled (slot, centre distance, faces, their distances).
  w.put(static_cast<uint64_t>(surface ? surface->slots() : 0));
  w.put(static_cast<uint64_t>(surface ? surface->cells_made() : 0));
  if (surface)
    surface->for_each_cell([&](size_t slot, const ClosestGrid::Cell& c) {
      w.put(static_cast<uint64_t>(slot));
      w.put(c.centre_distance_m);
      w.put_all(c.faces);
      w.put_all(c.face_m);
    });
  const std::string why = write_checked(path, kLookupMagic, key, w.bytes());
  if (why.empty()) prune_beside(path, ".lookup", keep_files);
  return why;
}

PartFileRead load_part_lookups(const std::string& path, uint64_t key, PartModel& model, size_t faces) {
  MappedFile file;
  const PartFileRead got = read_checked(path, kLookupMagic, key, file);
  if (got != PartFileRead::kRead) return got;
  return read_part_lookups_body(body_at(file), body_bytes(file), model, faces) ? PartFileRead::kRead
                                                                               : PartFileRead::kDamaged;
}

bool read_part_lookups_body(const char* body, size_t body_size, PartModel& model, size_t faces) {
  using Slots = BrickSlots<int>;
  // Checked whole before any of it goes in: bricks of this grid, each slot empty or a sample's answer; cells
  // of the closest-face grid, each with faces of the mesh, as many distances as faces, nearest first.
  Reader r(body, body_size);
  uint64_t capacity = 0, bricks = 0;
  if (!r.get(capacity) || capacity != model.cache.brick_capacity() || !r.get(bricks) || bricks > capacity)
    return false;
  const char* first = nullptr;
  constexpr size_t kBrickBytes =
      2 * sizeof(uint64_t) + Slots::kBrickSlots * sizeof(int);  // index, count, slots
  if (!r.skip(bricks, kBrickBytes, first)) return false;
  const int most = static_cast<int>(model.pts.size()) + 1;  // a slot holds 0, or the answer (-1..n-1) + 2
  for (size_t k = 0; k < bricks; ++k) {
    uint64_t head[2];
    std::memcpy(head, first + k * kBrickBytes, sizeof head);
    if (head[0] >= capacity || head[1] != Slots::kBrickSlots) return false;
    int slots[Slots::kBrickSlots];
    std::memcpy(slots, first + k * kBrickBytes + sizeof head, sizeof slots);
    for (int v : slots)
      if (v < 0 || v > most) return false;
  }
  uint64_t cell_slots = 0, cells = 0;
  ClosestGrid* surface = model.surface.get();
  if (!r.get(cell_slots) || cell_slots != (surface ? surface->slots() : 0) || !r.get(cells) ||
      cells > cell_slots)
    return false;
  std::vector<std::pair<uint64_t, ClosestGrid::Cell>> read;
  read.reserve(std::min<uint64_t>(cells, body_size / (3 * sizeof(uint64_t) + sizeof(double))));
  for (uint64_t k = 0; k < cells; ++k) {
    uint64_t slot = 0;
    ClosestGrid::Cell c;
    if (!r.get(slot) || slot >= cell_slots || !r.get(c.centre_distance_m) || !r.get_all(c.faces) ||
        !r.get_all(c.face_m) || c.faces.size() != c.face_m.size())
      return false;
    for (size_t i = 0; i < c.faces.size(); ++i)
      if (c.faces[i] >= faces || !(c.face_m[i] >= 0.0) || (i > 0 && c.face_m[i] < c.face_m[i - 1]))
        return false;
    read.emplace_back(slot, std::move(c));
  }
  if (!r.done()) return false;
  for (size_t k = 0; k < bricks; ++k) {
    uint64_t b = 0;
    std::memcpy(&b, first + k * kBrickBytes, sizeof b);
    int* brick = model.cache.made_brick(b);
    std::memcpy(brick, first + k * kBrickBytes + 2 * sizeof(uint64_t), Slots::kBrickSlots * sizeof(int));
  }
  for (auto& [slot, c] : read) surface->put_cell(slot, std::move(c));
  return true;
}

}  // namespace weldtwin
