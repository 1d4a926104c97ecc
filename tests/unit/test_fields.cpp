// FieldWriter: HDF5 contents read back exactly, XDMF index consistent with the .h5, failures
// leave earlier frames intact; plot_curves.py produces a PNG.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "io/fields.hpp"

namespace fs = std::filesystem;
using namespace fdem;

namespace {

std::string source_dir() {
#ifdef FDEM_SOURCE_DIR
  return FDEM_SOURCE_DIR;
#else
  return fs::absolute(fs::path(__FILE__)).parent_path().parent_path().parent_path().string();
#endif
}

/// A fresh, empty folder under the system temp dir, removed at the end of the test.
struct TempDir {
  fs::path path;
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path = fs::temp_directory_path() / ("fdem_fields_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Two disjoint tets (discontinuous mesh: 8 nodes), values varying with the frame number k.
struct Model {
  std::vector<Vec3> x, u, v;
  std::vector<std::array<int, 4>> tets{{0, 1, 2, 3}, {4, 5, 6, 7}};
  std::vector<Sym3> stress;
  std::vector<real> vm, rank{0, 1}, active{1, 1};
  std::vector<std::array<int, 3>> faces;
  std::vector<real> damage;
  std::vector<int> mode;

  explicit Model(int k) {
    const Vec3 ref[8] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {2, 1, 1}, {1, 2, 1}, {1, 1, 2}};
    for (int i = 0; i < 8; ++i) {
      Vec3 d{1e-3 * k * i, -2e-4 * k, 0.1 / 3.0 * k};
      u.push_back(d);
      x.push_back(ref[i] + d);
      v.push_back({0.5 * k, -1.0 / 7.0, 1e-9 * i});
    }
    for (int e = 0; e < 2; ++e) {
      Sym3 s{-1e6 * (k + 1), 2e5 + e, 3e5, 4e4 * k, -5e4, 6.25e4 * e};
      stress.push_back(s);
      vm.push_back(von_mises(s));
    }
    if (k > 0) {  // a crack appears in the second frame
      faces = {{1, 2, 3}, {4, 5, 6}};
      damage = {0.25, 1.0};
      mode = {0, 3};
    }
  }
  FieldFrame frame(real t, long step, const std::string& label) const {
    FieldFrame f;
    f.time = t;
    f.step = step;
    f.label = label;
    f.x = &x;
    f.u = &u;
    f.v = &v;
    f.tets = &tets;
    f.stress = &stress;
    f.von_mises = &vm;
    f.extra = {{"rank", &rank}, {"active", &active}};
    f.crack_faces = &faces;
    f.crack_damage = &damage;
    f.crack_mode = &mode;
    return f;
  }
};

// ---------------------------------------------------------------- HDF5 read-back

struct H5File {
  hid_t id;
  explicit H5File(const std::string& p) : id(H5Fopen(p.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT)) {}
  ~H5File() {
    if (id >= 0) H5Fclose(id);
  }
};

std::vector<hsize_t> dims_of(hid_t file, const std::string& path) {
  std::vector<hsize_t> d;
  hid_t ds = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
  if (ds < 0) return d;
  hid_t sp = H5Dget_space(ds);
  int rank = H5Sget_simple_extent_ndims(sp);
  d.resize(rank > 0 ? rank : 0);
  if (rank > 0) H5Sget_simple_extent_dims(sp, d.data(), nullptr);
  H5Sclose(sp);
  H5Dclose(ds);
  return d;
}

template <class T>
std::vector<T> read_all(hid_t file, const std::string& path, hid_t memtype) {
  std::vector<hsize_t> d = dims_of(file, path);
  EXPECT_FALSE(d.empty()) << path;
  std::size_t n = 1;
  for (hsize_t x : d) n *= x;
  std::vector<T> out(n);
  hid_t ds = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
  EXPECT_GE(H5Dread(ds, memtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), 0) << path;
  H5Dclose(ds);
  return out;
}

bool path_exists(hid_t file, const std::string& path) {
  // Walk component by component: H5Lexists on "a/b" needs "a" to exist.
  std::string cur;
  std::stringstream ss(path);
  std::string part;
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    cur += "/" + part;
    if (H5Lexists(file, cur.c_str(), H5P_DEFAULT) <= 0) return false;
  }
  return !cur.empty();
}

void expect_frame(hid_t file, const std::string& g, const Model& m, real t, long step, const std::string& label) {
  using V = std::vector<double>;
  auto flat3 = [](const std::vector<Vec3>& a) {
    V o;
    for (auto& p : a) o.insert(o.end(), {p.x, p.y, p.z});
    return o;
  };
  EXPECT_EQ(read_all<double>(file, g + "/x", H5T_NATIVE_DOUBLE), flat3(m.x));
  EXPECT_EQ(read_all<double>(file, g + "/u", H5T_NATIVE_DOUBLE), flat3(m.u));
  EXPECT_EQ(read_all<double>(file, g + "/v", H5T_NATIVE_DOUBLE), flat3(m.v));
  EXPECT_EQ(dims_of(file, g + "/x"), (std::vector<hsize_t>{8, 3}));
  V s;
  for (auto& q : m.stress) s.insert(s.end(), {q.xx, q.yy, q.zz, q.xy, q.yz, q.xz});
  EXPECT_EQ(read_all<double>(file, g + "/stress", H5T_NATIVE_DOUBLE), s);
  EXPECT_EQ(dims_of(file, g + "/stress"), (std::vector<hsize_t>{2, 6}));
  EXPECT_EQ(read_all<double>(file, g + "/von_mises", H5T_NATIVE_DOUBLE), m.vm);
  EXPECT_EQ(read_all<double>(file, g + "/rank", H5T_NATIVE_DOUBLE), m.rank);
  EXPECT_EQ(read_all<double>(file, g + "/active", H5T_NATIVE_DOUBLE), m.active);
  if (m.faces.empty()) {
    EXPECT_FALSE(path_exists(file, g + "/crack_faces"));
  } else {
    std::vector<int> fl;
    for (auto& fc : m.faces) fl.insert(fl.end(), fc.begin(), fc.end());
    EXPECT_EQ(read_all<int>(file, g + "/crack_faces", H5T_NATIVE_INT), fl);
    EXPECT_EQ(dims_of(file, g + "/crack_faces"), (std::vector<hsize_t>{2, 3}));
    EXPECT_EQ(read_all<double>(file, g + "/crack_damage", H5T_NATIVE_DOUBLE), m.damage);
    EXPECT_EQ(read_all<int>(file, g + "/crack_mode", H5T_NATIVE_INT), m.mode);
  }
  // attributes
  hid_t grp = H5Gopen2(file, g.c_str(), H5P_DEFAULT);
  ASSERT_GE(grp, 0) << g;
  double tv = -1;
  long long sv = -1;
  hid_t a = H5Aopen(grp, "time", H5P_DEFAULT);
  H5Aread(a, H5T_NATIVE_DOUBLE, &tv);
  H5Aclose(a);
  a = H5Aopen(grp, "step", H5P_DEFAULT);
  H5Aread(a, H5T_NATIVE_LLONG, &sv);
  H5Aclose(a);
  a = H5Aopen(grp, "label", H5P_DEFAULT);
  hid_t ty = H5Aget_type(a);
  std::string lab(H5Tget_size(ty), '\0');
  H5Aread(a, ty, lab.data());
  lab = lab.c_str();  // drop null padding
  H5Tclose(ty);
  H5Aclose(a);
  H5Gclose(grp);
  EXPECT_EQ(tv, t);
  EXPECT_EQ(sv, step);
  EXPECT_EQ(lab, label);
}

// ---------------------------------------------------------------- XDMF checks

/// Minimal XML well-formedness: every start tag is closed in order, one root element.
::testing::AssertionResult balanced_xml(const std::string& s) {
  std::vector<std::string> stack;
  int roots = 0;
  std::size_t i = 0;
  while ((i = s.find('<', i)) != std::string::npos) {
    std::size_t j = s.find('>', i);
    if (j == std::string::npos) return ::testing::AssertionFailure() << "unterminated tag at " << i;
    std::string tag = s.substr(i + 1, j - i - 1);
    i = j + 1;
    if (tag.empty()) return ::testing::AssertionFailure() << "empty tag";
    if (tag[0] == '?' || tag[0] == '!') continue;
    if (tag[0] == '/') {
      std::string name = tag.substr(1);
      if (stack.empty() || stack.back() != name)
        return ::testing::AssertionFailure()
               << "</" << name << "> does not close " << (stack.empty() ? "anything" : "<" + stack.back() + ">");
      stack.pop_back();
      continue;
    }
    std::string name = tag.substr(0, tag.find_first_of(" \t\n/"));
    if (stack.empty()) ++roots;
    if (tag.back() != '/') stack.push_back(name);
  }
  if (!stack.empty()) return ::testing::AssertionFailure() << "<" << stack.back() << "> never closed";
  if (roots != 1) return ::testing::AssertionFailure() << roots << " root elements";
  return ::testing::AssertionSuccess();
}

/// Every HDF DataItem names a dataset of the .h5 with exactly the declared dimensions.
void expect_index_matches_h5(const std::string& xdmf, const std::string& h5path, const std::string& h5name,
                             int* items_checked) {
  H5File f(h5path);
  ASSERT_GE(f.id, 0);
  std::regex item(R"re(<DataItem Dimensions="([0-9 ]+)"[^>]*Format="HDF">([^<:]+):([^<]+)</DataItem>)re");
  int n = 0;
  for (std::sregex_iterator it(xdmf.begin(), xdmf.end(), item), end; it != end; ++it, ++n) {
    const std::string dims = (*it)[1], file = (*it)[2], path = (*it)[3];
    EXPECT_EQ(file, h5name);
    ASSERT_TRUE(path_exists(f.id, path)) << path << " is referenced by the XDMF but not in the .h5";
    std::vector<hsize_t> d = dims_of(f.id, path);
    std::ostringstream got;
    for (std::size_t k = 0; k < d.size(); ++k) got << (k ? " " : "") << d[k];
    EXPECT_EQ(got.str(), dims) << path;
  }
  *items_checked = n;
}

int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t i = s.find(what); i != std::string::npos; i = s.find(what, i + 1)) ++n;
  return n;
}

}  // namespace

TEST(FieldWriter, TwoFramesRoundTripExactly) {
  TempDir tmp;
  const fs::path folder = tmp.path / "out" / "nested";  // created by the writer
  Model m0(0), m1(1);
  FieldWriter w(folder.string(), "fields");
  EXPECT_EQ(w.frames(), 0);
  w.write(m0.frame(0.0, 0, ""));
  w.write(m1.frame(1.25e-5, 500, "peak"));
  EXPECT_EQ(w.frames(), 2);
  const fs::path h5 = folder / "fields.h5", xd = folder / "fields.xdmf";
  ASSERT_TRUE(fs::exists(h5));
  ASSERT_TRUE(fs::exists(xd));
  EXPECT_FALSE(fs::exists(folder / "fields.xdmf.tmp"));

  {
    H5File f(h5.string());
    ASSERT_GE(f.id, 0);
    std::vector<int> t;
    for (auto& e : m0.tets) t.insert(t.end(), e.begin(), e.end());
    EXPECT_EQ(read_all<int>(f.id, "/mesh/tets", H5T_NATIVE_INT), t);
    EXPECT_EQ(dims_of(f.id, "/mesh/tets"), (std::vector<hsize_t>{2, 4}));
    expect_frame(f.id, "/frame_000000", m0, 0.0, 0, "");
    expect_frame(f.id, "/frame_000001", m1, 1.25e-5, 500, "peak");
    EXPECT_FALSE(path_exists(f.id, "/frame_000000/tets"));  // topology written once
  }

  const std::string x = slurp(xd);
  EXPECT_TRUE(balanced_xml(x));
  EXPECT_NE(x.find("CollectionType=\"Temporal\""), std::string::npos);
  EXPECT_NE(x.find("Name=\"frame_000000\""), std::string::npos);
  EXPECT_NE(x.find("Name=\"frame_000001_peak\""), std::string::npos);
  EXPECT_EQ(count(x, "<Time Value="), 2);
  EXPECT_EQ(count(x, "<Grid Name=\"rock\""), 2);
  EXPECT_EQ(count(x, "<Grid Name=\"cracks\""), 1);  // frame 0 has no crack faces
  EXPECT_NE(x.find("TopologyType=\"Tetrahedron\" NumberOfElements=\"2\""), std::string::npos);
  EXPECT_NE(x.find("TopologyType=\"Triangle\" NumberOfElements=\"2\""), std::string::npos);
  EXPECT_NE(x.find("<Time Value=\"1.2500000000000001e-05\"/>"), std::string::npos);
  for (const char* a : {"\"u\"", "\"v\"", "\"stress\"", "\"von_mises\"", "\"rank\"", "\"active\"", "\"D\"", "\"mode\""})
    EXPECT_NE(x.find(std::string("Attribute Name=") + a), std::string::npos) << a;
  int items = 0;
  expect_index_matches_h5(x, h5.string(), "fields.h5", &items);
  EXPECT_EQ(items, 20);  // 8 per rock grid (x, tets, u, v, stress, von_mises, rank, active) x 2 + 4 for one cracks grid
}

TEST(FieldWriter, RelabelChangesTheIndexAndTheAttributeOnly) {
  TempDir tmp;
  Model m0(0), m1(1);
  FieldWriter w(tmp.path.string(), "fields");
  w.write(m0.frame(0.0, 0, "peak"));
  w.write(m1.frame(1.25e-5, 500, ""));
  w.relabel(0, "local-peak");
  w.relabel(1, "peak");
  EXPECT_THROW(w.relabel(2, "x"), RunError);
  {
    H5File f((tmp.path / "fields.h5").string());
    expect_frame(f.id, "/frame_000000", m0, 0.0, 0, "local-peak");
    expect_frame(f.id, "/frame_000001", m1, 1.25e-5, 500, "peak");
  }
  const std::string x = slurp(tmp.path / "fields.xdmf");
  EXPECT_TRUE(balanced_xml(x));
  EXPECT_NE(x.find("Name=\"frame_000000_local-peak\""), std::string::npos);
  EXPECT_NE(x.find("<Information Name=\"label\" Value=\"local-peak\"/>"), std::string::npos);
  EXPECT_NE(x.find("Name=\"frame_000001_peak\""), std::string::npos);
  EXPECT_EQ(count(x, "\"frame_000001\""), 0);
  int items = 0;
  expect_index_matches_h5(x, (tmp.path / "fields.h5").string(), "fields.h5", &items);
  EXPECT_EQ(items, 20);
}

TEST(FieldWriter, NonFiniteThrowsAndKeepsPreviousIndex) {
  TempDir tmp;
  Model m0(0), m1(1);
  FieldWriter w(tmp.path.string(), "run");
  w.write(m0.frame(0.0, 0, ""));
  const std::string before = slurp(tmp.path / "run.xdmf");

  Model bad = m1;
  bad.v[5].y = std::numeric_limits<real>::quiet_NaN();
  try {
    w.write(bad.frame(1.0, 10, ""));
    FAIL() << "NaN velocity was accepted";
  } catch (const RunError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("v[5]"), std::string::npos) << msg;
  }
  Model bad2 = m1;
  bad2.stress[1].xz = std::numeric_limits<real>::infinity();
  try {
    w.write(bad2.frame(1.0, 10, ""));
    FAIL() << "infinite stress was accepted";
  } catch (const RunError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("stress[1]"), std::string::npos) << msg;
  }
  Model bad3 = m1;
  bad3.damage[1] = std::nan("");
  EXPECT_THROW(w.write(bad3.frame(1.0, 10, "")), RunError);
  Model bad4 = m1;
  bad4.tets[1][2] = 8;  // out of range node id
  EXPECT_THROW(w.write(bad4.frame(1.0, 10, "")), RunError);

  EXPECT_EQ(w.frames(), 1);
  const std::string after = slurp(tmp.path / "run.xdmf");
  EXPECT_EQ(after, before);
  EXPECT_TRUE(balanced_xml(after));
  int items = 0;
  expect_index_matches_h5(after, (tmp.path / "run.h5").string(), "run.h5", &items);
  EXPECT_GT(items, 0);
  {
    H5File f((tmp.path / "run.h5").string());
    EXPECT_FALSE(path_exists(f.id, "/frame_000001"));  // nothing half-written
  }

  // The writer is still usable after the rejected frames.
  w.write(m1.frame(1.0, 10, "final"));
  EXPECT_EQ(w.frames(), 2);
  H5File f((tmp.path / "run.h5").string());
  expect_frame(f.id, "/frame_000001", m1, 1.0, 10, "final");
}

TEST(FieldWriter, TopologyChangeGetsItsOwnTets) {
  TempDir tmp;
  Model m0(0), m1(1);
  m1.tets[0] = {3, 2, 1, 0};
  FieldWriter w(tmp.path.string(), "topo");
  w.write(m0.frame(0.0, 0, ""));
  w.write(m1.frame(1.0, 1, ""));
  const std::string x = slurp(tmp.path / "topo.xdmf");
  EXPECT_NE(x.find("topo.h5:/frame_000001/tets"), std::string::npos);
  H5File f((tmp.path / "topo.h5").string());
  EXPECT_EQ(read_all<int>(f.id, "/frame_000001/tets", H5T_NATIVE_INT), (std::vector<int>{3, 2, 1, 0, 4, 5, 6, 7}));
  int items = 0;
  expect_index_matches_h5(x, (tmp.path / "topo.h5").string(), "topo.h5", &items);
}

TEST(FieldWriter, UnwritableFolderThrowsWithPath) {
  TempDir tmp;
  const fs::path blocker = tmp.path / "not_a_dir";
  std::ofstream(blocker) << "x";
  const std::string folder = (blocker / "sub").string();
  try {
    FieldWriter w(folder, "fields");
    Model m(0);
    w.write(m.frame(0, 0, ""));
    FAIL() << "writing under a regular file succeeded";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find(folder), std::string::npos) << e.what();
  }
}

TEST(FieldWriter, Hdf5FailureNamesTheFileAndKeepsIndex) {
  TempDir tmp;
  Model m0(0);
  FieldWriter w(tmp.path.string(), "gone");
  w.write(m0.frame(0, 0, ""));
  const std::string before = slurp(tmp.path / "gone.xdmf");
  const fs::path h5 = tmp.path / "gone.h5";
  fs::remove(h5);
  std::ofstream(h5) << "not an HDF5 file";
  try {
    w.write(m0.frame(1, 1, ""));
    FAIL() << "writing into a corrupt .h5 succeeded";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find(h5.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(w.frames(), 1);
  EXPECT_EQ(slurp(tmp.path / "gone.xdmf"), before);
}

TEST(FieldWriter, StaleIndexIsRemovedOnRestart) {
  TempDir tmp;
  Model m0(0);
  {
    FieldWriter w(tmp.path.string(), "again");
    w.write(m0.frame(0, 0, ""));
    w.write(m0.frame(1, 1, ""));
  }
  FieldWriter w2(tmp.path.string(), "again");
  EXPECT_FALSE(fs::exists(tmp.path / "again.xdmf"));
  w2.write(m0.frame(0, 0, ""));
  EXPECT_EQ(count(slurp(tmp.path / "again.xdmf"), "<Grid Name=\"rock\""), 1);
}

// ---------------------------------------------------------------- plot script

TEST(PlotCurves, WritesPng) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "/usr/bin/python3 cannot import matplotlib";
  TempDir tmp;
  const fs::path csv = tmp.path / "monitors.csv", png = tmp.path / "curves.png";
  {
    std::ofstream c(csv);
    c << "time,step,axial_strain,axial_stress_Pa,lateral_strain,volumetric_strain,broken_ce6\n";
    for (int i = 0; i <= 40; ++i) {
      const double ea = 1e-4 * i;
      const double s =
          i <= 25 ? 4e10 * ea * (1 - ea / 0.006) : 4e10 * 0.0025 * (1 - 0.0025 / 0.006) * (1 - 0.04 * (i - 25));
      const double el = -0.25 * ea - (i > 20 ? 2e-4 * (i - 20) * 1e-1 : 0);
      c << 1e-6 * i << "," << 10 * i << "," << ea << "," << s << "," << el << "," << ea + 2 * el << ","
        << (i > 20 ? (i - 20) * (i - 20) : 0) << "\n";
    }
  }
  const std::string script = source_dir() + "/scripts/plot_curves.py";
  ASSERT_TRUE(fs::exists(script)) << script;
  const std::string cmd = "/usr/bin/python3 '" + script + "' '" + csv.string() + "' '" + png.string() +
                          "' --title 'unit test' >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  ASSERT_TRUE(fs::exists(png));
  std::ifstream in(png, std::ios::binary);
  char sig[8] = {};
  in.read(sig, 8);
  EXPECT_EQ(std::string(sig, 8), std::string("\x89PNG\r\n\x1a\n", 8));

  // Missing file and header-only CSV fail with a non-zero exit.
  const std::string missing = "/usr/bin/python3 '" + script + "' '" + (tmp.path / "nope.csv").string() + "' '" +
                              (tmp.path / "x.png").string() + "' >/dev/null 2>&1";
  EXPECT_NE(std::system(missing.c_str()), 0);
  const fs::path empty = tmp.path / "empty.csv";
  std::ofstream(empty) << "axial_strain,axial_stress_Pa\n";
  const std::string none = "/usr/bin/python3 '" + script + "' '" + empty.string() + "' '" +
                           (tmp.path / "y.png").string() + "' >/dev/null 2>&1";
  EXPECT_NE(std::system(none.c_str()), 0);
  EXPECT_FALSE(fs::exists(tmp.path / "y.png"));
}

TEST(AtomicFile, ReplacesWholeAndFailsCleanly) {
  TempDir tmp;
  const fs::path p = tmp.path / "summary.csv";
  write_file_atomically(p.string(), "a,b\n1,2\n");
  EXPECT_EQ(slurp(p), "a,b\n1,2\n");
  write_file_atomically(p.string(), "x\n");  // replaced, not appended
  EXPECT_EQ(slurp(p), "x\n");
  EXPECT_FALSE(fs::exists(tmp.path / "summary.csv.tmp"));
  const fs::path nowhere = tmp.path / "no_such_folder" / "f.csv";
  try {
    write_file_atomically(nowhere.string(), "x");
    FAIL() << "no error for a missing folder";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find(nowhere.string() + ".tmp"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(nowhere));
}
