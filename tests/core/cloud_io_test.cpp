// weldtwin's PCD and PLY reader and writer against PCL's own (the reference for both formats): what PCL
// writes (ascii, binary, binary_compressed; PLY ascii and binary) reads back point for point, what weldtwin
// writes PCL reads back point for point, big-endian PLY with other elements and properties around the
// vertices, and truncated files refused with the file named.
#include <gtest/gtest.h>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "tests/real_data.hpp"

namespace weldtwin {
namespace {

const std::filesystem::path dir = std::filesystem::temp_directory_path() / "weldtwin_cloud_io_test";

pcl::PointCloud<pcl::PointWithViewpoint> random_cloud(size_t n, bool with_nan) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  pcl::PointCloud<pcl::PointWithViewpoint> c;
  for (size_t i = 0; i < n; ++i)
    c.push_back(pcl::PointWithViewpoint(u(rng), u(rng), u(rng), u(rng), u(rng), u(rng)));
  if (with_nan) {
    c[3].x = std::numeric_limits<float>::quiet_NaN();
    c[7].vp_z = std::numeric_limits<float>::infinity();
    c.is_dense = false;
  }
  return c;
}

TEST(CloudIo, ReadsWhatPclWritesPointForPoint) {
  std::filesystem::create_directories(dir);
  const auto cloud = random_cloud(5000, true);
  pcl::PCDWriter writer;
  const std::pair<const char*, int> modes[] = {{"ascii", 0}, {"binary", 1}, {"compressed", 2}};
  for (const auto& [name, mode] : modes) {
    const std::string file = (dir / (std::string("pcl_") + name + ".pcd")).string();
    ASSERT_EQ(mode == 0   ? writer.writeASCII(file, cloud, 9)
              : mode == 1 ? writer.writeBinary(file, cloud)
                          : writer.writeBinaryCompressed(file, cloud),
              0);
    size_t dropped = 0;
    std::vector<Vec3> vp;
    const std::vector<Vec3> pts = read_cloud(file, &dropped, &vp);
    ASSERT_EQ(pts.size(), cloud.size() - 2) << name;
    ASSERT_EQ(vp.size(), pts.size()) << name;
    EXPECT_EQ(dropped, 2u) << name;
    size_t j = 0;
    for (size_t i = 0; i < cloud.size(); ++i) {
      if (i == 3 || i == 7) continue;
      // Binary: the very floats; ascii (9 digits): the same floats once rounded to float.
      const auto& p = cloud[i];
      EXPECT_EQ(pts[j].cast<float>(), Eigen::Vector3f(p.x, p.y, p.z)) << name << " " << i;
      EXPECT_EQ(vp[j].cast<float>(), Eigen::Vector3f(p.vp_x, p.vp_y, p.vp_z)) << name << " " << i;
      if (mode != 0) {
        EXPECT_EQ(pts[j], Vec3(p.x, p.y, p.z)) << name << " " << i;
      }
      ++j;
    }
  }
  // Plain x y z, and a cloud with other fields around them (PCL's PointXYZRGBNormal): x y z still found.
  pcl::PointCloud<pcl::PointXYZRGBNormal> other;
  for (const auto& p : cloud) {
    pcl::PointXYZRGBNormal q;
    q.x = p.vp_x, q.y = p.vp_y, q.z = p.vp_z, q.normal_x = 1.0f, q.rgb = 0.5f;
    other.push_back(q);
  }
  const std::string file = (dir / "pcl_rgbnormal.pcd").string();
  ASSERT_EQ(writer.writeBinaryCompressed(file, other), 0);
  std::vector<Vec3> vp{{1, 2, 3}};
  const std::vector<Vec3> pts = read_cloud(file, nullptr, &vp);
  EXPECT_TRUE(vp.empty());
  ASSERT_EQ(pts.size(), other.size() - 1);  // the infinite one
  EXPECT_EQ(pts[0], Vec3(other[0].x, other[0].y, other[0].z));
}

// PCL's own test clouds (ascii with normals, an old header, binary_compressed with colour, an organised cloud
// with NaN points, PLY), where the real-data folder is present: every finite point PCL reads, ours reads too,
// the same floats in the same order.
TEST(CloudIo, PclsOwnTestCloudsReadAsPclReadsThem) {
  const std::string clouds = test::real_data("clouds");
  if (!std::filesystem::exists(clouds + "/bun0.pcd")) GTEST_SKIP() << "skipped: " << clouds << " not found";
  for (const char* name : {"bun0.pcd", "bun4.pcd", "milk_color.pcd", "noisy_slice_displaced.pcd",
                           "sac_plane_test.pcd", "table_scene_mug_stereo_textured.pcd", "cube.ply"}) {
    SCOPED_TRACE(name);
    const std::string file = clouds + "/" + name;
    pcl::PointCloud<pcl::PointXYZ> reference;
    const bool ply = std::string(name).find(".ply") != std::string::npos;
    ASSERT_EQ(ply ? pcl::io::loadPLYFile(file, reference) : pcl::io::loadPCDFile(file, reference), 0);
    std::vector<Eigen::Vector3f> finite;
    for (const auto& p : reference)
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) finite.emplace_back(p.x, p.y, p.z);
    size_t dropped = 0;
    const std::vector<Vec3> ours = read_cloud(file, &dropped);
    ASSERT_EQ(ours.size(), finite.size());
    EXPECT_EQ(dropped, reference.size() - finite.size());
    for (size_t i = 0; i < ours.size(); ++i) ASSERT_EQ(ours[i].cast<float>(), finite[i]) << i;
  }
}

TEST(CloudIo, PclReadsWhatWeldtwinWrites) {
  std::filesystem::create_directories(dir);
  const auto cloud = random_cloud(3000, false);
  std::vector<Vec3> pts, vps;
  for (const auto& p : cloud) pts.emplace_back(p.x, p.y, p.z), vps.emplace_back(p.vp_x, p.vp_y, p.vp_z);
  for (bool ascii : {false, true}) {
    const std::string file = (dir / (ascii ? "ours_ascii.pcd" : "ours_binary.pcd")).string();
    write_pcd(file, pts, ascii, &vps);
    pcl::PointCloud<pcl::PointWithViewpoint> back;
    ASSERT_EQ(pcl::PCDReader().read(file, back), 0);
    ASSERT_EQ(back.size(), cloud.size());
    for (size_t i = 0; i < cloud.size(); ++i) {
      EXPECT_EQ(back[i].x, cloud[i].x) << i;
      EXPECT_EQ(back[i].vp_z, cloud[i].vp_z) << i;
    }
  }
}

TEST(CloudIo, ReadsPlyAsciiBinaryAndBigEndian) {
  std::filesystem::create_directories(dir);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (const auto& p : random_cloud(2000, false)) cloud.push_back(pcl::PointXYZ(p.x, p.y, p.z));
  for (bool binary : {false, true}) {
    const std::string file = (dir / (binary ? "pcl_binary.ply" : "pcl_ascii.ply")).string();
    ASSERT_EQ(pcl::PLYWriter().write(file, cloud, binary, false), 0);
    const std::vector<Vec3> pts = read_cloud(file);
    ASSERT_EQ(pts.size(), cloud.size()) << binary;
    for (size_t i = 0; i < cloud.size(); ++i)
      ASSERT_LE((pts[i] - Vec3(cloud[i].x, cloud[i].y, cloud[i].z)).norm(), binary ? 0.0 : 1e-5) << i;
  }
  // Big-endian doubles, a face element (with a list) before the vertices, an extra property between them.
  const std::string file = (dir / "big.ply").string();
  {
    std::ofstream out(file, std::ios::binary);
    out << "ply\nformat binary_big_endian 1.0\ncomment by hand\nelement face 1\nproperty list uchar int "
           "vertex_indices\nelement vertex 2\nproperty double x\nproperty uchar flag\nproperty double y\n"
           "property double z\nend_header\n";
    auto put = [&](const void* v, size_t n) {
      std::vector<char> b(static_cast<const char*>(v), static_cast<const char*>(v) + n);
      std::reverse(b.begin(), b.end());
      out.write(b.data(), static_cast<std::streamsize>(n));
    };
    const unsigned char three = 3;
    out.write(reinterpret_cast<const char*>(&three), 1);
    for (int k : {0, 1, 1}) put(&k, 4);
    const double v[2][3] = {{0.25, -1.5, 3.0}, {1e-3, 2.0, -0.125}};
    for (const auto& r : v) {
      put(&r[0], 8);
      out.put(7);
      put(&r[1], 8);
      put(&r[2], 8);
    }
  }
  const std::vector<Vec3> pts = read_cloud(file);
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[0], Vec3(0.25, -1.5, 3.0));
  EXPECT_EQ(pts[1], Vec3(1e-3, 2.0, -0.125));
}

// Ascii numbers are read to the same double the C library's correctly rounded parse gives (strtod), in every
// way clouds write them: short and long decimals, 15-17 significant digits, leading zeros, negative zero,
// exponents, integers, a leading plus; a reader that rounds its own way is off in the last bit somewhere
// here.
TEST(CloudIo, AsciiNumbersReadToTheCorrectlyRoundedDouble) {
  std::filesystem::create_directories(dir);
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-2.5, 2.5);
  std::vector<std::string> words{"0",
                                 "-0",
                                 "-0.0",
                                 "0.1",
                                 "0.3",
                                 "1.",
                                 ".5",
                                 "-.25",
                                 "+1.5",
                                 "1e-3",
                                 "-2.5E+2",
                                 "007.500",
                                 "0.000000000000000000001",
                                 "123456789012345",
                                 "1234567890123456",
                                 "0.12345678901234567890",
                                 "9007199254740993",
                                 "-1.7976931348623157e308"};
  const char* formats[] = {"%.3f", "%.6f", "%.9g", "%.15g", "%.17g", "%.12f", "%.20f"};
  for (int i = 0; i < 4000; ++i) {
    char buf[64];
    std::snprintf(buf, sizeof buf, formats[i % 7], u(rng) * std::pow(10.0, i % 5 - 2));
    words.push_back(buf);
  }
  while (words.size() % 3) words.push_back("1");
  const std::string file = (dir / "numbers.pcd").string();
  {
    std::ofstream out(file);
    out << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " << words.size() / 3
        << "\nHEIGHT 1\nPOINTS " << words.size() / 3 << "\nDATA ascii\n";
    for (size_t i = 0; i < words.size(); i += 3)
      out << words[i] << " " << words[i + 1] << "\t" << words[i + 2] << (i % 2 ? "\r\n" : "\n");
  }
  const std::vector<Vec3> pts = read_cloud(file);
  ASSERT_EQ(pts.size(), words.size() / 3);
  for (size_t i = 0; i < words.size(); ++i) {
    const double want = std::strtod(words[i].c_str(), nullptr), got = pts[i / 3][static_cast<int>(i % 3)];
    EXPECT_EQ(std::memcmp(&want, &got, sizeof want), 0) << words[i] << ": " << got << " against " << want;
  }
}

TEST(CloudIo, TruncatedFilesAreRefusedNamingTheFile) {
  std::filesystem::create_directories(dir);
  std::vector<Vec3> pts(100, Vec3(0.1, 0.2, 0.3));
  const std::string full = (dir / "full.pcd").string(), cut = (dir / "cut_binary.pcd").string();
  write_pcd(full, pts);
  std::string bytes;
  {
    std::ifstream in(full, std::ios::binary);
    bytes.assign((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 50);
  try {
    read_cloud(cut);
    FAIL() << "a truncated cloud was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cut_binary.pcd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  const std::string ply = (dir / "cut.ply").string();
  std::ofstream(ply) << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                        "property float z\nend_header\n1 2 3\n4 5\n";
  EXPECT_THROW(read_cloud(ply), InputError);
  std::ofstream((dir / "nofields.pcd").string()) << "VERSION 0.7\nFIELDS a b\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\n"
                                                    "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2\n";
  EXPECT_THROW(read_cloud((dir / "nofields.pcd").string()), InputError);
  // A header claiming far more points than the file holds (or a count that wraps): refused, nothing reserved.
  for (const char* claim : {"POINTS 1000000000000", "POINTS -5"})
    for (const char* data : {"ascii", "binary", "binary_compressed"}) {
      const std::string file = (dir / "claims.pcd").string();
      std::ofstream(file)
          << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
          << claim << "\nDATA " << data << "\n0123456789abcdef0123";
      EXPECT_THROW(read_cloud(file), InputError) << claim << " " << data;
    }
}

// What mutated headers did before (each allocated for what the header said, not what the file held: 8 GB
// for a COUNT of 1e9, 4 GiB for a compressed block of 2 bytes; a COUNT of 2^31-1 overflowed to an internal
// error; POINTS below WIDTH x HEIGHT dropped points silently): now one clear error naming the file.
TEST(CloudIo, HeadersPromisingMoreThanTheFileHoldsAreRefusedBeforeAllocating) {
  std::filesystem::create_directories(dir);
  const std::string file = (dir / "promise.pcd").string();
  auto refused = [&](const std::string& bytes, const std::string& says) {
    std::ofstream(file, std::ios::binary) << bytes;
    try {
      read_cloud(file);
      ADD_FAILURE() << "read: " << bytes.substr(0, 120);
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("promise.pcd"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  const std::string head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n";
  const std::string ten = "0.3 0.1 0.0\n0.3 0.1 0.0\n0.3 0.1 0.0\n0.3 0.1 0.0\n0.3 0.1 0.0\n";
  for (const char* count : {"2147483647", "1000000000", "-1", "99999999999999999999"})
    refused(head + "COUNT " + count + " 1 1\nWIDTH 5\nHEIGHT 1\nPOINTS 5\nDATA ascii\n" + ten, "COUNT");
  refused(head + "COUNT 1 1 1\nWIDTH 10\nHEIGHT 1\nPOINTS 5\nDATA ascii\n" + ten, "WIDTH x HEIGHT");
  // A compressed block of 2 bytes claiming to unpack to 357913941 x 12 bytes.
  std::string body(8, '\0');
  const uint32_t sizes[2] = {2, 357913941u * 12u};
  std::memcpy(body.data(), sizes, 8);
  body += "ab";
  refused(head + "COUNT 1 1 1\nWIDTH 357913941\nHEIGHT 1\nPOINTS 357913941\nDATA binary_compressed\n" + body,
          "the header claims 357913941 points");
  // PLY: an element without properties holds nothing whatever its count (it had been looped over 1e15 times);
  // a vertex count the file cannot hold, or a negative one, is refused at once.
  const std::string ply = (dir / "promise.ply").string();
  const std::string props = "property float x\nproperty float y\nproperty float z\nend_header\n";
  for (const char* junk : {"1000000000000000", "18446744073709551615"}) {
    std::ofstream(ply) << "ply\nformat ascii 1.0\nelement junk " << junk << "\nelement vertex 1\n"
                       << props << "0 0 0";
    EXPECT_EQ(read_cloud(ply).size(), 1u) << junk;
  }
  for (const char* count : {"1000000000000000", "-1", "12abc"}) {
    std::ofstream(ply) << "ply\nformat binary_little_endian 1.0\nelement vertex " << count << "\n"
                       << props << std::string(24, '\0');
    EXPECT_THROW(read_cloud(ply), InputError) << count;
  }
  // The same header with an honest count reads.
  std::ofstream(file) << head << "COUNT 1 1 1\nWIDTH 5\nHEIGHT 1\nPOINTS 5\nDATA ascii\n" << ten;
  EXPECT_EQ(read_cloud(file).size(), 5u);
}

}  // namespace
}  // namespace weldtwin
