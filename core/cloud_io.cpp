// PCD and PLY point clouds, read and written here rather than through PCL's I/O module: that module pulls in
// VTK, OpenNI and some forty other libraries whose loading cost every `weldtwin` process 0.1-0.15 s before
// main(), and its ASCII reader took another 0.1 s for 58,000 points (see benchmarks/RESULTS.md). The formats
// are PCL's own (PCD 0.7: ascii, binary and binary_compressed through liblzf, as PCL writes it) and the
// Stanford PLY (ascii, binary little and big endian); tests check both against PCL's reader and writer.
#include "core/cloud_io.hpp"

#include <liblzf/lzf.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "core/error.hpp"
#include "core/files.hpp"
#include "core/mapped_file.hpp"

namespace weldtwin {
namespace {

// LZF's longest back-reference copies 264 bytes from 3: no LZF block expands more than about 88-fold.
constexpr size_t kLzfMaxRatio = 90;

// The file's bytes (mapped: core/mapped_file.hpp), or an InputError naming it.
void map_file(const std::string& path, MappedFile& file) {
  if (!is_file(path)) throw input_error(path, "no such file");
  if (!file.map(path)) throw input_error(path, "cannot open the file");
  if (file.size() == 0) throw input_error(path, "empty file");
}

// A scalar of `size` bytes and kind F (float), I (signed) or U (unsigned) at p, as a double.
double scalar(const char* p, char kind, int size, bool big_endian = false) {
  unsigned char b[8];
  std::memcpy(b, p, static_cast<size_t>(size));
  if (big_endian) std::reverse(b, b + size);
  switch (kind) {
    case 'F':
      if (size == 4) {
        float f;
        std::memcpy(&f, b, 4);
        return f;
      } else {
        double d;
        std::memcpy(&d, b, 8);
        return d;
      }
    case 'I': {
      int64_t v = 0;
      std::memcpy(&v, b, static_cast<size_t>(size));
      const int shift = 64 - 8 * size;  // sign-extend
      return static_cast<double>(static_cast<int64_t>(static_cast<uint64_t>(v) << shift) >> shift);
    }
    default: {
      uint64_t v = 0;
      std::memcpy(&v, b, static_cast<size_t>(size));
      return static_cast<double>(v);
    }
  }
}

bool is_separator(const char* c, const char* end) {
  return c == end || std::isspace(static_cast<unsigned char>(*c));
}

// A plain decimal ([-]digits[.digits], ended by white space or the end) whose digits make an integer below
// 2^53 with at most kMaxExactPower of them after the point, the way nearly every ascii cloud writes its
// numbers: digits / 10^k, both exact in a double, and one division is correctly rounded (Clinger's fast
// path), so the value is the one from_chars gives, at a fraction of its cost. False (p untouched) for
// anything else.
constexpr int kMaxExactPower = 22;                 // 10^22 is the largest exact power of ten
constexpr long kMaxDigits = 19;                    // any 19 digits fit a uint64_t
constexpr uint64_t kMaxExact = uint64_t{1} << 53;  // every integer up to this is an exact double
constexpr double kPow10[kMaxExactPower + 1] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                               1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                               1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

bool parse_plain_decimal(const char*& p, const char* end, double& v) {
  const char* c = p;
  const bool negative = c < end && *c == '-';
  if (negative) ++c;
  auto digit = [&] { return c < end && static_cast<unsigned>(*c - '0') < 10u; };
  const char* first = c;
  uint64_t digits = 0;
  for (; digit(); ++c) digits = digits * 10 + static_cast<unsigned>(*c - '0');
  long count = c - first, after_point = 0;
  if (c < end && *c == '.') {
    const char* fraction = ++c;
    for (; digit(); ++c) digits = digits * 10 + static_cast<unsigned>(*c - '0');
    after_point = c - fraction;
    count += after_point;
  }
  if (count == 0 || count > kMaxDigits || digits > kMaxExact || after_point > kMaxExactPower ||
      !is_separator(c, end))
    return false;
  const double magnitude = static_cast<double>(digits) / kPow10[after_point];
  v = negative ? -magnitude : magnitude;
  p = c;
  return true;
}

bool parse_double(const char*& p, const char* end, double& v) {
  while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
  if (p >= end || *p == '\n') return false;
  if (parse_plain_decimal(p, end, v)) return true;
  const char* start = p;
  const auto r = std::from_chars(start, end, v);
  if (r.ec == std::errc() && is_separator(r.ptr, end)) {
    p = r.ptr;
    return true;
  }
  while (p < end && !is_separator(p, end)) ++p;
  std::string token(start, p);  // nan, inf, +1.5 and the like
  char* stop = nullptr;
  v = std::strtod(token.c_str(), &stop);
  return stop && *stop == '\0' && stop != token.c_str();
}

// The layout of one point record: where x, y, z and (if present) vp_x, vp_y, vp_z are.
struct Field {
  std::string name;
  int size = 4, count = 1;
  char kind = 'F';
  size_t offset = 0;  // byte offset in a binary record
  size_t column = 0;  // first value's index in an ascii line
};

struct Layout {
  std::vector<Field> fields;
  int want[6] = {-1, -1, -1, -1, -1, -1};  // x y z vp_x vp_y vp_z -> field index
  size_t record = 0;                       // bytes per point (binary)
  bool has_viewpoints() const { return want[3] >= 0 && want[4] >= 0 && want[5] >= 0; }
};

void collect(const Vec3& p, const Vec3& v, bool with_vp, std::vector<Vec3>& out, std::vector<Vec3>* vps,
             size_t& dropped) {
  if (!p.allFinite() || (with_vp && !v.allFinite())) {
    ++dropped;
    return;
  }
  out.push_back(p);
  if (with_vp) vps->push_back(v);
}

std::vector<Vec3> read_pcd(const std::string& path, size_t& dropped, std::vector<Vec3>* viewpoints) {
  MappedFile file;
  map_file(path, file);
  const std::string_view data = file.view();
  Layout L;
  std::vector<std::string> names, sizes, types, counts;
  size_t points = 0, width = 0, height = 1, pos = 0;
  bool have_points = false;
  std::string format;
  auto words = [](const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> w;
    for (std::string s; in >> s;) w.push_back(s);
    return w;
  };
  while (pos < data.size() && format.empty()) {
    const size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) break;
    const std::string line(data.substr(pos, eol - pos));
    pos = eol + 1;
    std::vector<std::string> w = words(line);
    if (w.empty() || w[0][0] == '#') continue;
    const std::string key = w[0];
    w.erase(w.begin());
    try {
      if (key == "FIELDS" || key == "COLUMNS")
        names = w;
      else if (key == "SIZE")
        sizes = w;
      else if (key == "TYPE")
        types = w;
      else if (key == "COUNT")
        counts = w;
      else if (key == "WIDTH" && !w.empty())
        width = std::stoul(w[0]);
      else if (key == "HEIGHT" && !w.empty())
        height = std::stoul(w[0]);
      else if (key == "POINTS" && !w.empty())
        points = std::stoul(w[0]), have_points = true;
      else if (key == "DATA" && !w.empty())
        format = w[0];
    } catch (const std::exception&) {
      throw input_error(path, "malformed PCD header line '" + line + "'");
    }
  }
  if (format.empty()) throw input_error(path, "malformed or truncated point cloud (no DATA line)");
  if (!have_points) points = width * height;
  if (have_points && width > 0 && points != width * height)
    throw input_error(path, "malformed PCD header: POINTS " + std::to_string(points) +
                                " but WIDTH x HEIGHT " + std::to_string(width) + " x " +
                                std::to_string(height));
  const size_t body_bytes = data.size() - pos;
  // The most bytes of point data the body can stand for: its own size, or what LZF can expand it to.
  const size_t max_data_bytes = format == "binary_compressed" ? body_bytes * kLzfMaxRatio : body_bytes;
  if (names.empty() || sizes.size() != names.size() || types.size() != names.size() ||
      (!counts.empty() && counts.size() != names.size()))
    throw input_error(path, "malformed PCD header: FIELDS, SIZE, TYPE and COUNT disagree");
  static const char* wanted[6] = {"x", "y", "z", "vp_x", "vp_y", "vp_z"};
  size_t column = 0;
  for (size_t i = 0; i < names.size(); ++i) {
    Field f;
    f.name = names[i];
    f.kind = types[i].empty() ? '?' : types[i][0];
    f.size = std::atoi(sizes[i].c_str());
    if (!counts.empty()) {
      // Each value takes at least a byte of data (two in ascii: a digit and a space).
      const long long c = std::strtoll(counts[i].c_str(), nullptr, 10);
      if (c < 1 || static_cast<unsigned long long>(c) > (max_data_bytes + 1) / (format == "ascii" ? 2 : 1))
        throw input_error(path, "malformed PCD header: COUNT " + counts[i] + " of field '" + names[i] +
                                    "' is more values than the file holds");
      f.count = static_cast<int>(c);
    }
    if ((f.kind != 'F' && f.kind != 'I' && f.kind != 'U') ||
        (f.size != 1 && f.size != 2 && f.size != 4 && f.size != 8) ||
        (f.kind == 'F' && f.size != 4 && f.size != 8) || f.count < 1)
      throw input_error(path, "malformed PCD header: field '" + f.name + "' of type " + types[i] + sizes[i]);
    f.offset = L.record;
    f.column = column;
    L.record += static_cast<size_t>(f.size) * static_cast<size_t>(f.count);
    column += static_cast<size_t>(f.count);
    if (format == "ascii" && column > (body_bytes + 1) / 2)
      throw input_error(path, "malformed PCD header: a point's values are more than the file holds");
    for (int k = 0; k < 6; ++k)
      if (f.name == wanted[k]) L.want[k] = static_cast<int>(i);
    L.fields.push_back(f);
  }
  if (L.want[0] < 0 || L.want[1] < 0 || L.want[2] < 0)
    throw input_error(path, "the cloud has no x, y, z fields");
  if (L.record > max_data_bytes)
    throw input_error(path, "malformed PCD header: one point's fields need more bytes than the file holds");
  // A header may claim more points than the file can hold (or a count that overflows): refuse before
  // reserving or reading anything.
  // At least: two bytes a value in ascii, a record in binary, a record per LZF's expansion when compressed.
  const size_t record = std::max<size_t>(1, L.record);
  const size_t holds = format == "ascii"               ? (body_bytes + 1) / (2 * std::max<size_t>(1, column))
                       : format == "binary_compressed" ? max_data_bytes / record
                                                       : body_bytes / record;
  if (points > holds ||
      (format == "binary_compressed" && points > std::numeric_limits<uint32_t>::max() / record))
    throw input_error(path, "truncated point cloud: the header claims " + std::to_string(points) +
                                " points, the file holds fewer");
  const bool with_vp = viewpoints && L.has_viewpoints();
  std::vector<Vec3> out;
  out.reserve(points);
  if (with_vp) viewpoints->reserve(points);
  Vec3 p, v = Vec3::Zero();
  if (format == "ascii") {
    const char* c = data.data() + pos;
    const char* end = data.data() + data.size();
    std::vector<double> values(column);
    size_t read = 0;
    while (read < points && c < end) {
      const char* eol = static_cast<const char*>(std::memchr(c, '\n', static_cast<size_t>(end - c)));
      if (!eol) eol = end;
      size_t n = 0;
      for (double x; n < values.size() && parse_double(c, eol, x);) values[n++] = x;
      if (n == 0) {  // a blank line
        c = eol + 1;
        continue;
      }
      if (n < values.size())
        throw input_error(path, "malformed PCD: point " + std::to_string(read) + " has " + std::to_string(n) +
                                    " of " + std::to_string(values.size()) + " values");
      auto at = [&](int k) { return values[L.fields[static_cast<size_t>(L.want[k])].column]; };
      p = Vec3(at(0), at(1), at(2));
      if (with_vp) v = Vec3(at(3), at(4), at(5));
      collect(p, v, with_vp, out, viewpoints, dropped);
      ++read;
      c = eol + 1;
    }
    if (read < points)
      throw input_error(path, "truncated point cloud: " + std::to_string(read) + " of " +
                                  std::to_string(points) + " points");
  } else if (format == "binary" || format == "binary_compressed") {
    std::string unpacked;
    const char* body = data.data() + pos;
    size_t body_size = data.size() - pos;
    if (format == "binary_compressed") {
      uint32_t sizes2[2] = {0, 0};
      if (body_size < 8) throw input_error(path, "truncated point cloud (no compressed block)");
      std::memcpy(sizes2, body, 8);
      if (sizes2[0] > body_size - 8 || sizes2[1] != L.record * points)
        throw input_error(path, "truncated or malformed compressed point cloud");
      if (sizes2[1] > static_cast<size_t>(sizes2[0]) * kLzfMaxRatio)
        throw input_error(path, "malformed compressed point cloud: " + std::to_string(sizes2[0]) +
                                    " compressed bytes cannot hold " + std::to_string(sizes2[1]) + " bytes");
      unpacked.resize(sizes2[1]);
      if (sizes2[1] > 0 && lzf_decompress(body + 8, sizes2[0], unpacked.data(), sizes2[1]) != sizes2[1])
        throw input_error(path, "malformed compressed point cloud (LZF)");
      body = unpacked.data();
      body_size = unpacked.size();
    }
    if (body_size < L.record * points)
      throw input_error(
          path, "truncated point cloud: " + std::to_string(body_size / std::max<size_t>(1, L.record)) +
                    " of " + std::to_string(points) + " points");
    const bool soa = format == "binary_compressed";  // compressed: each field's values one after the other
    auto at = [&](size_t i, int k) {
      const Field& f = L.fields[static_cast<size_t>(L.want[k])];
      const size_t off =
          soa ? f.offset * points + i * static_cast<size_t>(f.size) * static_cast<size_t>(f.count)
              : i * L.record + f.offset;
      return scalar(body + off, f.kind, f.size);
    };
    for (size_t i = 0; i < points; ++i) {
      p = Vec3(at(i, 0), at(i, 1), at(i, 2));
      if (with_vp) v = Vec3(at(i, 3), at(i, 4), at(i, 5));
      collect(p, v, with_vp, out, viewpoints, dropped);
    }
  } else {
    throw input_error(path, "unknown PCD data format '" + format + "'");
  }
  return out;
}

// PLY: the vertex element's x, y, z (and vp_x, vp_y, vp_z if there); elements before it are skipped. With
// `mesh`, every vertex is kept (none dropped: faces index them) and the face element's vertex_indices are
// read too, polygons as fans of triangles.
std::vector<Vec3> read_ply(const std::string& path, size_t& dropped, std::vector<Vec3>* viewpoints,
                           std::vector<Eigen::Vector3i>* mesh = nullptr) {
  MappedFile file;
  map_file(path, file);
  const std::string_view data = file.view();
  struct Prop {
    std::string name;
    char kind = 'F';
    int size = 4;
    bool list = false;
    char count_kind = 'U';
    int count_size = 1;
  };
  struct Element {
    std::string name;
    size_t count = 0;
    std::vector<Prop> props;
  };
  auto type_of = [&](const std::string& t, char& kind, int& size) {
    static const std::pair<const char*, std::pair<char, int>> types[] = {
        {"char", {'I', 1}},  {"int8", {'I', 1}},    {"uchar", {'U', 1}},  {"uint8", {'U', 1}},
        {"short", {'I', 2}}, {"int16", {'I', 2}},   {"ushort", {'U', 2}}, {"uint16", {'U', 2}},
        {"int", {'I', 4}},   {"int32", {'I', 4}},   {"uint", {'U', 4}},   {"uint32", {'U', 4}},
        {"float", {'F', 4}}, {"float32", {'F', 4}}, {"double", {'F', 8}}, {"float64", {'F', 8}}};
    for (const auto& [name, ks] : types)
      if (t == name) {
        kind = ks.first;
        size = ks.second;
        return;
      }
    throw input_error(path, "malformed PLY header: unknown type '" + t + "'");
  };
  if (data.compare(0, 3, "ply") != 0) throw input_error(path, "not a PLY file (no 'ply' magic)");
  std::vector<Element> elements;
  std::string format;
  size_t pos = 0;
  bool ended = false;
  while (pos < data.size()) {
    const size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) break;
    std::istringstream line(std::string(data.substr(pos, eol - pos)));
    pos = eol + 1;
    std::string key;
    line >> key;
    if (key == "format") {
      line >> format;
    } else if (key == "element") {
      Element e;
      std::string count;
      line >> e.name >> count;
      const auto r = std::from_chars(count.data(), count.data() + count.size(), e.count);
      if (!line || count.empty() || r.ec != std::errc() || r.ptr != count.data() + count.size())
        throw input_error(path, "malformed PLY header: element line '" + e.name + " " + count + "'");
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) throw input_error(path, "malformed PLY header: property before any element");
      Prop p;
      std::string t;
      line >> t;
      if (t == "list") {
        std::string ct, it;
        line >> ct >> it;
        p.list = true;
        type_of(ct, p.count_kind, p.count_size);
        type_of(it, p.kind, p.size);
      } else {
        type_of(t, p.kind, p.size);
      }
      line >> p.name;
      elements.back().props.push_back(p);
    } else if (key == "end_header") {
      ended = true;
      break;
    }
  }
  if (!ended) throw input_error(path, "malformed or truncated PLY header (no end_header)");
  const bool ascii = format == "ascii", big = format == "binary_big_endian";
  if (!ascii && !big && format != "binary_little_endian")
    throw input_error(path, "unknown PLY format '" + format + "'");
  std::vector<Vec3> out;
  const char* c = data.data() + pos;
  const char* end = data.data() + data.size();
  auto truncated = [&]() { return input_error(path, "truncated PLY data"); };
  for (const Element& e : elements) {
    const bool vertex = e.name == "vertex";
    int index_list = -1;  // the face element's list of vertex indices
    if (mesh && e.name == "face")
      for (size_t i = 0; i < e.props.size(); ++i)
        if (e.props[i].list && (e.props[i].name == "vertex_indices" || e.props[i].name == "vertex_index"))
          index_list = static_cast<int>(i);
    std::vector<double> polygon;
    int want[6] = {-1, -1, -1, -1, -1, -1};
    static const char* wanted[6] = {"x", "y", "z", "vp_x", "vp_y", "vp_z"};
    for (size_t i = 0; i < e.props.size(); ++i)
      for (int k = 0; k < 6; ++k)
        if (!e.props[i].list && e.props[i].name == wanted[k]) want[k] = static_cast<int>(i);
    if (vertex && (want[0] < 0 || want[1] < 0 || want[2] < 0))
      throw input_error(path, "the cloud has no x, y, z fields");
    const bool with_vp = vertex && viewpoints && want[3] >= 0 && want[4] >= 0 && want[5] >= 0;
    // An element's record takes at least a byte per property (two in ascii): a count the rest of the file
    // cannot hold is refused before anything is read; an element without properties holds no data at all.
    size_t least = 0;
    for (const Prop& p : e.props) least += ascii ? 2 : static_cast<size_t>(p.list ? p.count_size : p.size);
    if (least == 0) continue;
    if (e.count > (static_cast<size_t>(end - c) + 1) / least)  // + 1: the last value needs no separator
      throw input_error(path, "truncated PLY data: the header claims " + std::to_string(e.count) + " " +
                                  e.name + " elements, the file holds fewer");
    std::vector<double> values(e.props.size(), 0.0);
    for (size_t n = 0; n < e.count; ++n) {
      for (size_t i = 0; i < e.props.size(); ++i) {
        const Prop& p = e.props[i];
        if (ascii) {
          double x = 0.0;
          while (c < end && std::isspace(static_cast<unsigned char>(*c))) ++c;
          if (!parse_double(c, end, x)) throw truncated();
          if (p.list) {
            if (!(x >= 0)) throw input_error(path, "malformed PLY data: a list of " + std::to_string(x));
            polygon.clear();
            for (double k = 0; k < x; ++k) {
              double item;
              while (c < end && std::isspace(static_cast<unsigned char>(*c))) ++c;
              if (!parse_double(c, end, item)) throw truncated();
              if (static_cast<int>(i) == index_list) polygon.push_back(item);
            }
          } else {
            values[i] = x;
          }
        } else if (p.list) {
          if (end - c < p.count_size) throw truncated();
          const double k = scalar(c, p.count_kind, p.count_size, big);
          c += p.count_size;
          if (k < 0 || (end - c) / p.size < k) throw truncated();
          if (static_cast<int>(i) == index_list) {
            polygon.clear();
            for (size_t j = 0; j < static_cast<size_t>(k); ++j)
              polygon.push_back(scalar(c + j * static_cast<size_t>(p.size), p.kind, p.size, big));
          }
          c += static_cast<size_t>(k) * static_cast<size_t>(p.size);
        } else {
          if (end - c < p.size) throw truncated();
          values[i] = scalar(c, p.kind, p.size, big);
          c += p.size;
        }
      }
      if (index_list >= 0) {
        for (size_t k = 2; k < polygon.size(); ++k) {
          const double ids[3] = {polygon[0], polygon[k - 1], polygon[k]};
          for (double id : ids)
            if (!(id >= 0 && id < static_cast<double>(out.size()))) {
              char named[32];  // the index as the file has it (it may not fit an integer)
              std::snprintf(named, sizeof named, "%.15g", id);
              throw input_error(path, "malformed PLY mesh: face " + std::to_string(n) + " names vertex " +
                                          named + " of " + std::to_string(out.size()));
            }
          mesh->emplace_back(static_cast<int>(ids[0]), static_cast<int>(ids[1]), static_cast<int>(ids[2]));
        }
      }
      if (!vertex) continue;
      auto at = [&](int k) { return values[static_cast<size_t>(want[k])]; };
      if (mesh) {
        out.emplace_back(at(0), at(1), at(2));
        continue;
      }
      collect(Vec3(at(0), at(1), at(2)), with_vp ? Vec3(at(3), at(4), at(5)) : Vec3::Zero(), with_vp, out,
              viewpoints, dropped);
    }
    if (vertex && !mesh) break;
  }
  return out;
}

}  // namespace

std::vector<Vec3> read_ply_mesh(const std::string& path, std::vector<Eigen::Vector3i>& faces) {
  size_t dropped = 0;
  faces.clear();
  return read_ply(path, dropped, nullptr, &faces);
}

void write_pcd(const std::string& path, const std::vector<Vec3>& points, bool ascii,
               const std::vector<Vec3>* viewpoints) {
  if (viewpoints && viewpoints->size() != points.size())
    throw std::invalid_argument(path + ": one viewpoint per point is needed");
  const size_t n = points.size();
  const bool vp = viewpoints != nullptr;
  std::ostringstream head;
  head << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
       << (vp ? "FIELDS x y z vp_x vp_y vp_z\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\nCOUNT 1 1 1 1 1 1\n"
              : "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n")
       << "WIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA "
       << (ascii ? "ascii" : "binary") << "\n";
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(path + ": cannot write the point cloud");
  out << head.str();
  const size_t per = vp ? 6 : 3;
  if (ascii) {
    char buf[48];
    for (size_t i = 0; i < n; ++i) {
      for (size_t k = 0; k < per; ++k) {
        const float f = static_cast<float>(k < 3 ? points[i][static_cast<Eigen::Index>(k)]
                                                 : (*viewpoints)[i][static_cast<Eigen::Index>(k - 3)]);
        const auto r = std::to_chars(buf, buf + sizeof buf, f);
        out.write(buf, r.ptr - buf);
        out.put(k + 1 < per ? ' ' : '\n');
      }
    }
  } else {
    std::vector<float> body(n * per);
    for (size_t i = 0; i < n; ++i)
      for (size_t k = 0; k < per; ++k)
        body[i * per + k] = static_cast<float>(k < 3 ? points[i][static_cast<Eigen::Index>(k)]
                                                     : (*viewpoints)[i][static_cast<Eigen::Index>(k - 3)]);
    out.write(reinterpret_cast<const char*>(body.data()),
              static_cast<std::streamsize>(body.size() * sizeof(float)));
  }
  if (!out) throw std::runtime_error(path + ": cannot write the point cloud");
}

std::vector<Vec3> read_cloud(const std::string& path, size_t* dropped_non_finite,
                             std::vector<Vec3>* viewpoints) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (viewpoints) viewpoints->clear();
  size_t dropped = 0;
  std::vector<Vec3> out;
  if (ext == ".pcd" || ext == ".PCD") {
    out = read_pcd(path, dropped, viewpoints);
  } else if (ext == ".ply" || ext == ".PLY") {
    out = read_ply(path, dropped, viewpoints);
  } else {
    if (!is_file(path)) throw input_error(path, "no such file");
    throw input_error(path, "unknown cloud format '" + ext + "' (expected .pcd or .ply)");
  }
  if (dropped_non_finite) *dropped_non_finite = dropped;
  return out;
}

}  // namespace weldtwin
