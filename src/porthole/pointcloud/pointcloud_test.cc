// Proves every reader (PLY ascii/binary LE/BE, XYZ/CSV/TXT, OBJ, STL ascii/binary) returns the
// points written into small hand-made files, and that malformed files raise InvalidInput naming the
// file and the line or byte offset.
#include "porthole/pointcloud/pointcloud.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>

#include "porthole/core/error.h"

namespace porthole::pointcloud {
namespace {

namespace fs = std::filesystem;

fs::path Dir() {
  const fs::path d = fs::temp_directory_path() / "porthole_pointcloud_test";
  fs::create_directories(d);
  return d;
}

fs::path WriteBytes(const std::string& name, const std::string& bytes) {
  const fs::path p = Dir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return p;
}

template <typename T>
void Append(std::string& s, T v, bool big_endian = false) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

// Runs f and checks it throws InvalidInput whose message contains every one of `parts`.
void ExpectInvalid(const std::function<void()>& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no exception";
  } catch (const InvalidInput& e) {
    for (const auto& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << " lacks " << p;
  }
}

const Eigen::Matrix3Xd kThree = (Eigen::Matrix3Xd(3, 3) << 1.5, -2, 3.25,  //
                                 0, 10, -7.5,                              //
                                 1e3, 0.125, 42)
                                    .finished();

// ------------------------------------------------------------------ PLY

TEST(PlyRead, AsciiSkipsOtherPropertiesAndElements) {
  const auto p = WriteBytes("a.ply",
                            "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\n"
                            "element camera 1\r\nproperty float f\r\n"
                            "element vertex 3\r\nproperty uchar red\r\nproperty float x\r\n"
                            "property float y\r\nproperty double z\r\nproperty float nx\r\n"
                            "element face 1\r\nproperty list uchar int vertex_indices\r\n"
                            "end_header\r\n"
                            "35.0\r\n"
                            "255 1.5 0 1000 0.1\r\n7 -2 10 0.125 0\r\n0 3.25 -7.5 42 0\r\n"
                            "3 0 1 2\r\n");
  const PointCloud c = ReadPointCloud(p);
  ASSERT_EQ(c.size(), 3);
  EXPECT_TRUE(c.points.isApprox(kThree, 0)) << c.points;
}

// Binary PLY of kThree: a short "id" before x, float/double x y z, a uchar after, then a face
// element with a list; `big` selects big endian.
std::string BinaryPly(bool big, bool doubles) {
  const std::string t = doubles ? "double" : "float";
  std::string s = std::string("ply\nformat ") +
                  (big ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\nelement vertex 3\nproperty short id\nproperty " + t + " x\nproperty " + t +
                  " y\nproperty " + t +
                  " z\nproperty uchar flag\n"
                  "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 3; ++i) {
    Append<int16_t>(s, static_cast<int16_t>(i), big);
    for (int k = 0; k < 3; ++k) {
      if (doubles)
        Append<double>(s, kThree(k, i), big);
      else
        Append<float>(s, static_cast<float>(kThree(k, i)), big);
    }
    Append<uint8_t>(s, 9);
  }
  for (int f = 0; f < 2; ++f) {
    Append<uint8_t>(s, 3);
    for (int k = 0; k < 3; ++k) Append<int32_t>(s, k, big);
  }
  return s;
}

TEST(PlyRead, BinaryLittleAndBigEndianFloatAndDouble) {
  for (bool big : {false, true}) {
    for (bool doubles : {false, true}) {
      const auto p = WriteBytes("b.ply", BinaryPly(big, doubles));
      const PointCloud c = ReadPointCloud(p);
      ASSERT_EQ(c.size(), 3);
      // kThree is exactly representable in float.
      EXPECT_TRUE(c.points.isApprox(kThree, 0)) << big << doubles << "\n" << c.points;
    }
  }
}

TEST(PlyRead, UppercaseExtensionAndExplicitFormat) {
  const auto p = WriteBytes("UP.PLY", BinaryPly(false, true));
  EXPECT_EQ(ReadPointCloud(p).size(), 3);
  const auto q = WriteBytes("noext", BinaryPly(false, true));
  EXPECT_EQ(ReadPointCloud(q, {.format = Format::kPly}).size(), 3);
}

TEST(PlyWrite, BinaryAndAsciiRoundTripWithResidual) {
  Eigen::VectorXd r(3);
  r << 0.001, -0.5, 2.0;
  for (bool binary : {true, false}) {
    const fs::path p = Dir() / (binary ? "rt_bin.ply" : "rt_ascii.ply");
    WritePointCloud(p, kThree, &r, {.binary = binary});
    const PointCloud c = ReadPointCloud(p);
    EXPECT_TRUE(c.points.isApprox(kThree, 1e-12)) << c.points;
    const std::string bytes = EncodePly(kThree, &r, binary);
    EXPECT_NE(bytes.find("property double residual"), std::string::npos);
    EXPECT_NE(bytes.find(binary ? "binary_little_endian" : "format ascii"), std::string::npos);
  }
  // Binary: the residual is stored as the 4th double of each vertex.
  const std::string bytes = EncodePly(kThree, &r, true);
  const size_t data = bytes.find("end_header\n") + 11;
  ASSERT_EQ(bytes.size(), data + 3 * 4 * 8);
  double v;
  std::memcpy(&v, bytes.data() + data + 4 * 8 + 3 * 8, 8);
  EXPECT_EQ(v, -0.5);
}

TEST(PlyWrite, XyzRoundTripAndSizeMismatch) {
  const fs::path p = Dir() / "rt.xyz";
  Eigen::VectorXd r = Eigen::VectorXd::Constant(3, 0.25);
  WritePointCloud(p, kThree, &r);
  EXPECT_TRUE(ReadPointCloud(p).points.isApprox(kThree, 1e-9));
  Eigen::VectorXd wrong(2);
  ExpectInvalid([&] { WritePointCloud(p, kThree, &wrong); }, {"2 scalar values for 3 points"});
  ExpectInvalid([&] { WritePointCloud(Dir() / "x.stl", kThree); }, {"only PLY and XYZ"});
  ExpectInvalid([&] { WritePointCloud(Dir() / "missing_dir" / "x.ply", kThree); },
                {"directory does not exist"});
}

TEST(PlyRead, Errors) {
  const std::string good = BinaryPly(false, false);
  // Truncated binary: the file ends 5 bytes into the second vertex.
  const size_t data = good.find("end_header\n") + 11;
  const size_t vertex_size = 2 + 3 * 4 + 1;
  const auto trunc = WriteBytes("trunc.ply", good.substr(0, data + vertex_size + 5));
  ExpectInvalid([&] { ReadPointCloud(trunc); },
                {"trunc.ply", "byte " + std::to_string(data + vertex_size + 5), "vertex"});
  // Extra bytes after the last element.
  const auto extra = WriteBytes("extra.ply", good + "xx");
  ExpectInvalid([&] { ReadPointCloud(extra); },
                {"byte " + std::to_string(good.size()), "after the last element"});
  // NaN in a binary vertex: byte offset of that vertex.
  std::string nan = good;
  const float q = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan.data() + data + vertex_size + 2 + 4, &q, 4);  // y of vertex 1
  const auto nanp = WriteBytes("nan.ply", nan);
  ExpectInvalid([&] { ReadPointCloud(nanp); },
                {"byte " + std::to_string(data + vertex_size), "not finite"});
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  // ASCII: too few vertex lines, too many, non-numeric, NaN, wrong value count.
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("few.ply", head + "1 2 3\n")); },
                {"few.ply", "line 9", "file ends after 1 of 2"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("many.ply", head + "1 2 3\n4 5 6\n7 8 9\n")); },
                {"line 10", "after the last element"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("abc.ply", head + "1 2 3\n4 abc 6\n")); },
                {"line 9", "not a number: 'abc'"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("nan2.ply", head + "1 2 3\n4 nan 6\n")); },
                {"line 9", "not finite"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("cnt.ply", head + "1 2 3 4\n4 5 6\n")); },
                {"line 8", "4 values where the header declares 3"});
  // ASCII list counts beyond the line's values, up to ones no integer holds (1e20 and inf became
  // INT64_MIN, an empty list, and the line was accepted; under clang's UBSan a float-cast-overflow).
  const std::string list_head =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nproperty list uchar int extra\nend_header\n";
  for (const std::string count : {"1e20", "inf", "9223372036854775808", "1"}) {
    ExpectInvalid([&] { ReadPointCloud(WriteBytes("listcount.ply", list_head + "1 2 3 " + count + "\n")); },
                  {"line 9", "list count " + count + " is more than the 0 values left"});
  }
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("listcount.ply", list_head + "1 2 3 3 7 8\n")); },
                {"line 9", "list count 3 is more than the 2 values left"});
  EXPECT_EQ(ReadPointCloud(WriteBytes("list.ply", list_head + "1 2 3 2 7 8\n")).points.cols(), 1);
  // Header problems.
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("magic.ply", "plx\n")); }, {"line 1", "magic"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("noend.ply", "ply\nformat ascii 1.0\n")); },
                {"end_header"});
  ExpectInvalid(
      [&] {
        ReadPointCloud(WriteBytes("noz.ply",
                                  "ply\nformat ascii 1.0\nelement vertex 1\n"
                                  "property float x\nproperty float y\nend_header\n1 2\n"));
      },
      {"x, y and z"});
  ExpectInvalid(
      [&] {
        ReadPointCloud(WriteBytes("type.ply",
                                  "ply\nformat ascii 1.0\nelement vertex 1\n"
                                  "property quad x\nend_header\n"));
      },
      {"line 4", "unknown property type 'quad'"});
  ExpectInvalid(
      [&] {
        ReadPointCloud(WriteBytes("empty.ply",
                                  "ply\nformat ascii 1.0\nelement vertex 0\n"
                                  "property float x\nproperty float y\nproperty float z\n"
                                  "end_header\n"));
      },
      {"no points"});
}

// ------------------------------------------------------------------ XYZ / CSV / TXT

TEST(XyzRead, SpacesTabsCommasHeaderCommentsExtraColumns) {
  const auto a = WriteBytes("a.xyz", "# scan\n1.5 0 1e3\n\n-2\t10  0.125 99\n3.25 -7.5 +42\n");
  EXPECT_TRUE(ReadPointCloud(a).points.isApprox(kThree, 0));
  const auto b = WriteBytes("b.csv",
                            "x,y,z,intensity\r\n1.5,0,1000,7\r\n-2, 10, 0.125,7\r\n"
                            "3.25,-7.5,42,7\r\n");
  EXPECT_TRUE(ReadPointCloud(b).points.isApprox(kThree, 0));
  const auto c = WriteBytes("c.txt", "X Y Z\n1.5 0 1000\n-2 10 0.125\n3.25 -7.5 42");
  EXPECT_TRUE(ReadPointCloud(c).points.isApprox(kThree, 0));
}

TEST(XyzRead, Errors) {
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e1.xyz", "1 2 3\n4 five 6\n")); },
                {"e1.xyz", "line 2", "field 2 is not a number: 'five'"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e2.xyz", "1 2 3\n4 5\n")); },
                {"line 2", "at least 3 fields"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e3.csv", "1,2,3\n1,,3\n")); },
                {"line 2", "field 2 is not a number: ''"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e4.xyz", "1 2 3\n1 NaN 3\n")); },
                {"line 2", "not finite"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e5.xyz", "1 2 3\n4 5 inf\n")); },
                {"line 2", "not finite"});
  // A second non-numeric line is not a header.
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e6.xyz", "x y z\nu v w\n")); },
                {"line 2", "not a number"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e7.xyz", "x y z\n")); }, {"no points"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("e8.las", "1 2 3\n")); },
                {"e8.las", "unknown point-cloud format '.las'"});
  ExpectInvalid([&] { ReadPointCloud(Dir() / "does_not_exist.xyz"); }, {"does not exist"});
}

// ------------------------------------------------------------------ OBJ

TEST(ObjRead, VerticesOnly) {
  const auto p = WriteBytes("m.obj",
                            "# obj\no thing\nv 1.5 0 1000\nvn 0 0 1\nvt 0.5 0.5\n"
                            "v -2 10 0.125 1.0\nv 3.25 -7.5 42 0.1 0.2 0.3\nf 1 2 3\n");
  EXPECT_TRUE(ReadPointCloud(p).points.isApprox(kThree, 0));
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("bad.obj", "v 1 2 3\nv 1 2\n")); },
                {"bad.obj", "line 2", "3 coordinates"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("bad2.obj", "\n\nv 1 x 3\n")); },
                {"line 3", "coordinate 2 is not a number: 'x'"});
}

// ------------------------------------------------------------------ STL

// Two triangles sharing an edge: 6 vertex records, 4 distinct vertices.
const float kTri[2][3][3] = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {0, 1, 0}}};

std::string BinaryStl(const std::string& header80) {
  std::string s = header80;
  s.resize(80, ' ');
  Append<uint32_t>(s, 2);
  for (const auto& tri : kTri) {
    for (int k = 0; k < 3; ++k) Append<float>(s, k == 2 ? 1.f : 0.f);
    for (const auto& v : tri)
      for (float c : v) Append<float>(s, c);
    Append<uint16_t>(s, 0);
  }
  return s;
}

TEST(StlRead, BinaryAndAsciiWithAndWithoutDeduplication) {
  std::string ascii = "solid t\n";
  for (const auto& tri : kTri) {
    ascii += " facet normal 0 0 1\n  outer loop\n";
    for (const auto& v : tri)
      ascii += "   vertex " + std::to_string(v[0]) + " " + std::to_string(v[1]) + " " +
               std::to_string(v[2]) + "\n";
    ascii += "  endloop\n endfacet\n";
  }
  ascii += "endsolid t\n";
  // A binary header that starts with "solid" must still be read as binary.
  for (const auto& [name, bytes] : std::vector<std::pair<std::string, std::string>>{
           {"a.stl", ascii}, {"b.stl", BinaryStl("binary")}, {"c.stl", BinaryStl("solid x")}}) {
    const auto p = WriteBytes(name, bytes);
    const PointCloud dedup = ReadPointCloud(p);
    ASSERT_EQ(dedup.size(), 4) << name;
    EXPECT_EQ(dedup.points.col(3), Eigen::Vector3d(1, 1, 0)) << name;
    EXPECT_EQ(ReadPointCloud(p, {.deduplicate_stl = false}).size(), 6) << name;
  }
}

TEST(StlRead, Errors) {
  const std::string good = BinaryStl("binary");
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("t.stl", good.substr(0, 84 + 50 + 20))); },
                {"t.stl", "byte 154", "facet 1 of 2"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("h.stl", good.substr(0, 40))); },
                {"byte 40", "84-byte"});
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("x.stl", good + "zz")); },
                {"byte 184", "after the 2 facets"});
  std::string nan = good;
  const float q = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan.data() + 84 + 50 + 12 + 12 + 4, &q, 4);  // facet 1, vertex 1, y
  ExpectInvalid([&] { ReadPointCloud(WriteBytes("n.stl", nan)); }, {"byte 158", "not finite"});
  ExpectInvalid(
      [&] {
        ReadPointCloud(WriteBytes("v2.stl",
                                  "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                                  "vertex 1 0 0\nendloop\nendfacet\nendsolid\n"));
      },
      {"line 7", "2 vertices"});
  ExpectInvalid(
      [&] {
        ReadPointCloud(WriteBytes("v3.stl",
                                  "solid s\nfacet normal 0 0 1\nouter loop\n"
                                  "vertex 0 zero 0\n"));
      },
      {"line 4", "not a number: 'zero'"});
}

}  // namespace
}  // namespace porthole::pointcloud
