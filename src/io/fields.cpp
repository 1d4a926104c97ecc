// HDF5 heavy data + XDMF 3 index for ParaView. See fields.hpp for the file layout.
#include "io/fields.hpp"

#include <hdf5.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>
#include <type_traits>

#include "core/error.hpp"
#include "io/atomic_file.hpp"

namespace fdem {
namespace {

static_assert(std::is_standard_layout<Vec3>::value && sizeof(Vec3) == 3 * sizeof(real), "Vec3 must be 3 packed reals");
static_assert(std::is_standard_layout<Sym3>::value && sizeof(Sym3) == 6 * sizeof(real), "Sym3 must be 6 packed reals");
static_assert(sizeof(std::array<int, 4>) == 4 * sizeof(int) && sizeof(std::array<int, 3>) == 3 * sizeof(int),
              "node-id arrays must be packed ints");
static_assert(sizeof(int) == 4, "node ids are written as int32");

// ---------------------------------------------------------------- HDF5 helpers

/// First (innermost) message on the HDF5 error stack, or "".
std::string h5_detail() {
  std::string out;
  auto walk = [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
    auto* s = static_cast<std::string*>(data);
    if (n == 0 && e) {
      *s = std::string(e->func_name ? e->func_name : "?") + ": " + (e->desc ? e->desc : "");
    }
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, walk, &out);
  H5Eclear2(H5E_DEFAULT);
  return out;
}

[[noreturn]] void h5_fail(const std::string& file, const std::string& what) {
  const int err = errno;  // (HDF5 keeps the system's reason of a failed write there)
  std::string d = h5_detail();
  const std::string why = write_failure(file, err);
  throw OutputError("HDF5 output " + file + ": " + what + " failed" + (d.empty() ? "" : " (" + d + ")") +
                    (why.find("disk is full") != std::string::npos ? ": " + why : ""));
}

/// Owns one HDF5 handle and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle(hid_t id, Closer c) : id_(id), close_(c) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }
  /// Closes now; returns false if the close itself failed (e.g. the final flush of a file).
  bool reset() {
    bool good = true;
    if (id_ >= 0) good = close_(id_) >= 0;
    id_ = -1;
    return good;
  }

 private:
  hid_t id_;
  Closer close_;
};

hid_t mem_real() {
  return std::is_same<real, double>::value ? H5T_NATIVE_DOUBLE : H5T_NATIVE_FLOAT;
}
hid_t file_real() {
  return std::is_same<real, double>::value ? H5T_IEEE_F64LE : H5T_IEEE_F32LE;
}

/// Writes a rank-1 (cols == 0) or rank-2 (rows x cols) dataset at loc/name.
void write_dataset(hid_t loc, const std::string& name, hid_t file_type, hid_t mem_type, const void* data, hsize_t rows,
                   hsize_t cols, const std::string& file, const std::string& where) {
  hsize_t dims[2] = {rows, cols};
  Handle space(H5Screate_simple(cols == 0 ? 1 : 2, dims, nullptr), H5Sclose);
  if (!space.ok()) h5_fail(file, "creating the dataspace of " + where);
  Handle ds(H5Dcreate2(loc, name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) h5_fail(file, "creating dataset " + where);
  if (rows > 0 && H5Dwrite(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    h5_fail(file, "writing dataset " + where);
  if (!ds.reset()) h5_fail(file, "closing dataset " + where);
}

void write_attr_real(hid_t loc, const char* name, real value, const std::string& file) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(loc, name, file_real(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!space.ok() || !a.ok() || H5Awrite(a.get(), mem_real(), &value) < 0)
    h5_fail(file, std::string("writing attribute ") + name);
}

void write_attr_long(hid_t loc, const char* name, long value, const std::string& file) {
  long long v = value;
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(loc, name, H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!space.ok() || !a.ok() || H5Awrite(a.get(), H5T_NATIVE_LLONG, &v) < 0)
    h5_fail(file, std::string("writing attribute ") + name);
}

void write_attr_string(hid_t loc, const char* name, const std::string& value, const std::string& file) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!type.ok() || H5Tset_size(type.get(), value.empty() ? 1 : value.size()) < 0 ||
      H5Tset_strpad(type.get(), H5T_STR_NULLPAD) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
    h5_fail(file, std::string("making the string type of attribute ") + name);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(loc, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  std::string buf = value.empty() ? std::string(1, '\0') : value;
  if (!space.ok() || !a.ok() || H5Awrite(a.get(), type.get(), buf.data()) < 0)
    h5_fail(file, std::string("writing attribute ") + name);
}

// ---------------------------------------------------------------- checks

void check_finite(const real* p, std::size_t count, int ncomp, const char* field, const std::string& file) {
  static const char* vec_comp[] = {"x", "y", "z"};
  static const char* sym_comp[] = {"xx", "yy", "zz", "yz", "xz", "xy"};
  for (std::size_t i = 0; i < count * ncomp; ++i) {
    if (!std::isfinite(p[i])) {
      std::ostringstream m;
      const std::size_t item = i / ncomp;
      m << "field output " << file << ": non-finite value " << p[i] << " in " << field << "[" << item << "]";
      if (ncomp == 3) m << "." << vec_comp[i % 3];
      if (ncomp == 6) m << "." << sym_comp[i % 6];
      m << " (the solver state must be finite; nothing was written for this frame)";
      throw RunError(m.str());
    }
  }
}

void check_size(std::size_t got, std::size_t want, const char* field, const char* what, const std::string& file) {
  if (got != want) {
    std::ostringstream m;
    m << "field output " << file << ": " << field << " has " << got << " entries but there are " << want << " " << what;
    throw RunError(m.str());
  }
}

template <std::size_t K>
void check_ids(const std::vector<std::array<int, K>>& ids, std::size_t nodes, const char* field,
               const std::string& file) {
  for (std::size_t i = 0; i < ids.size(); ++i)
    for (std::size_t k = 0; k < K; ++k)
      if (ids[i][k] < 0 || static_cast<std::size_t>(ids[i][k]) >= nodes) {
        std::ostringstream m;
        m << "field output " << file << ": " << field << "[" << i << "][" << k << "] = " << ids[i][k]
          << " is not a node id (there are " << nodes << " nodes)";
        throw RunError(m.str());
      }
}

// ---------------------------------------------------------------- XDMF helpers

std::string xml_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      case '\'':
        o += "&apos;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::string num(real v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", static_cast<double>(v));
  return b;
}

std::string dims_str(std::size_t rows, std::size_t cols) {
  return cols == 0 ? std::to_string(rows) : std::to_string(rows) + " " + std::to_string(cols);
}

std::string hdf_item(const std::string& h5, const std::string& path, std::size_t rows, std::size_t cols, bool is_int,
                     const std::string& indent) {
  std::ostringstream o;
  o << indent << "<DataItem Dimensions=\"" << dims_str(rows, cols) << "\" NumberType=\"" << (is_int ? "Int" : "Float")
    << "\" Precision=\"" << (is_int ? 4 : sizeof(real)) << "\" Format=\"HDF\">" << xml_escape(h5) << ":" << path
    << "</DataItem>\n";
  return o.str();
}

std::string attribute(const std::string& name, const char* type, const char* center, const std::string& item,
                      const std::string& indent) {
  return indent + "<Attribute Name=\"" + xml_escape(name) + "\" AttributeType=\"" + type + "\" Center=\"" + center +
         "\">\n" + item + indent + "</Attribute>\n";
}

std::string frame_name(int index) {
  char b[32];
  std::snprintf(b, sizeof b, "frame_%06d", index);
  return b;
}

/// Every check of a frame, made before the files are touched, so that a bad frame leaves no trace.
void validate_frame(const FieldFrame& f, const std::string& file) {
  if (!f.x) throw RunError("field output " + file + ": frame has no node positions (x)");
  if (!f.tets) throw RunError("field output " + file + ": frame has no tets");
  const std::size_t N = f.x->size(), M = f.tets->size();
  check_finite(&f.time, 1, 1, "time", file);
  check_finite(reinterpret_cast<const real*>(f.x->data()), N, 3, "x", file);
  if (f.u) {
    check_size(f.u->size(), N, "u", "nodes", file);
    check_finite(reinterpret_cast<const real*>(f.u->data()), N, 3, "u", file);
  }
  if (f.v) {
    check_size(f.v->size(), N, "v", "nodes", file);
    check_finite(reinterpret_cast<const real*>(f.v->data()), N, 3, "v", file);
  }
  check_ids(*f.tets, N, "tets", file);
  if (f.stress) {
    check_size(f.stress->size(), M, "stress", "tets", file);
    check_finite(reinterpret_cast<const real*>(f.stress->data()), M, 6, "stress", file);
  }
  if (f.von_mises) {
    check_size(f.von_mises->size(), M, "von_mises", "tets", file);
    check_finite(f.von_mises->data(), M, 1, "von_mises", file);
  }
  static const std::set<std::string> reserved = {
      "x", "u", "v", "tets", "stress", "von_mises", "crack_faces", "crack_damage", "crack_mode"};
  std::set<std::string> seen;
  for (const TetField& e : f.extra) {
    if (e.name.empty() || e.name.find('/') != std::string::npos || e.name == "." || reserved.count(e.name) ||
        !seen.insert(e.name).second)
      throw RunError("field output " + file + ": extra field name '" + e.name +
                     "' is empty, contains '/', is repeated or clashes with a built-in field");
    if (!e.values) throw RunError("field output " + file + ": extra field '" + e.name + "' has no values");
    check_size(e.values->size(), M, e.name.c_str(), "tets", file);
    check_finite(e.values->data(), M, 1, e.name.c_str(), file);
  }
  const std::size_t K = f.crack_faces ? f.crack_faces->size() : 0;
  if (K > 0) {
    check_ids(*f.crack_faces, N, "crack_faces", file);
    if (f.crack_damage) {
      check_size(f.crack_damage->size(), K, "crack_damage", "crack faces", file);
      check_finite(f.crack_damage->data(), K, 1, "crack_damage", file);
    }
    if (f.crack_mode) check_size(f.crack_mode->size(), K, "crack_mode", "crack faces", file);
  }
}

/// Frame `index` as an HDF5 group: its time, step and label, and its datasets. The first frame
/// also writes /mesh/tets; a later frame whose tets differ carries its own. Returns the path
/// of the frame's connectivity.
std::string write_frame_group(const FieldFrame& f, const std::string& file, int index, bool first_mesh,
                              bool new_topology) {
  const std::string gname = frame_name(index);
  const std::string gpath = "/" + gname;
  const std::size_t N = f.x->size(), M = f.tets->size();
  const std::size_t K = f.crack_faces ? f.crack_faces->size() : 0;
  std::string tets_path = "/mesh/tets";
  Handle h5(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
  if (!h5.ok()) h5_fail(file, "opening the file for frame " + std::to_string(index));
  // A frame group left behind by an earlier failed write() is replaced.
  if (H5Lexists(h5.get(), gname.c_str(), H5P_DEFAULT) > 0 && H5Ldelete(h5.get(), gname.c_str(), H5P_DEFAULT) < 0)
    h5_fail(file, "removing the incomplete group " + gpath);
  if (first_mesh) {
    if (H5Lexists(h5.get(), "mesh", H5P_DEFAULT) > 0 && H5Ldelete(h5.get(), "mesh", H5P_DEFAULT) < 0)
      h5_fail(file, "removing an incomplete /mesh");
    Handle mesh(H5Gcreate2(h5.get(), "mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    if (!mesh.ok()) h5_fail(file, "creating group /mesh");
    write_dataset(mesh.get(), "tets", H5T_STD_I32LE, H5T_NATIVE_INT, f.tets->data(), M, 4, file, "/mesh/tets");
  }
  Handle g(H5Gcreate2(h5.get(), gname.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.ok()) h5_fail(file, "creating group " + gpath);
  write_attr_real(g.get(), "time", f.time, file);
  write_attr_long(g.get(), "step", f.step, file);
  write_attr_string(g.get(), "label", f.label, file);
  if (new_topology && !first_mesh) {  // topology changed: this frame carries its own connectivity
    tets_path = gpath + "/tets";
    write_dataset(g.get(), "tets", H5T_STD_I32LE, H5T_NATIVE_INT, f.tets->data(), M, 4, file, tets_path);
  }
  auto wr = [&](const char* name, const void* data, std::size_t rows, std::size_t cols) {
    write_dataset(g.get(), name, file_real(), mem_real(), data, rows, cols, file, gpath + "/" + name);
  };
  wr("x", f.x->data(), N, 3);
  if (f.u) wr("u", f.u->data(), N, 3);
  if (f.v) wr("v", f.v->data(), N, 3);
  if (f.stress) {
    // VTK's order for symmetric tensors (xx, yy, zz, xy, yz, xz), so ParaView names the
    // components correctly.
    std::vector<real> vtk(6 * M);
    for (std::size_t t = 0; t < M; ++t) {
      const Sym3& q = (*f.stress)[t];
      const real row[6] = {q.xx, q.yy, q.zz, q.xy, q.yz, q.xz};
      std::copy(row, row + 6, vtk.begin() + 6 * t);
    }
    wr("stress", vtk.data(), M, 6);
  }
  if (f.von_mises) wr("von_mises", f.von_mises->data(), M, 0);
  for (const TetField& e : f.extra) wr(e.name.c_str(), e.values->data(), M, 0);
  if (K > 0) {
    write_dataset(g.get(), "crack_faces", H5T_STD_I32LE, H5T_NATIVE_INT, f.crack_faces->data(), K, 3, file,
                  gpath + "/crack_faces");
    if (f.crack_damage) wr("crack_damage", f.crack_damage->data(), K, 0);
    if (f.crack_mode)
      write_dataset(g.get(), "crack_mode", H5T_STD_I32LE, H5T_NATIVE_INT, f.crack_mode->data(), K, 0, file,
                    gpath + "/crack_mode");
  }
  if (!g.reset()) h5_fail(file, "closing group " + gpath);
  if (H5Fflush(h5.get(), H5F_SCOPE_GLOBAL) < 0) h5_fail(file, "flushing frame " + std::to_string(index));
  if (!h5.reset()) h5_fail(file, "closing the file after frame " + std::to_string(index));
  return tets_path;
}

/// The frame's XDMF grid: the rock tets with their fields, and the crack faces if any.
std::string xdmf_grid(const FieldFrame& f, const std::string& h5, int index, const std::string& tets_path) {
  const std::string gname = frame_name(index);
  const std::string gpath = "/" + gname;
  const std::size_t N = f.x->size(), M = f.tets->size();
  const std::size_t K = f.crack_faces ? f.crack_faces->size() : 0;
  std::string gridname = gname;
  if (!f.label.empty()) gridname += "_" + f.label;
  const std::string i3 = "      ", i4 = "        ", i5 = "          ";
  std::ostringstream o;
  o << "    <Grid Name=\"" << xml_escape(gridname) << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
    << i3 << "<Time Value=\"" << num(f.time) << "\"/>\n"
    << i3 << "<Information Name=\"step\" Value=\"" << f.step << "\"/>\n"
    << i3 << "<Information Name=\"label\" Value=\"" << xml_escape(f.label) << "\"/>\n";
  const std::string geometry =
      i4 + "<Geometry GeometryType=\"XYZ\">\n" + hdf_item(h5, gpath + "/x", N, 3, false, i5) + i4 + "</Geometry>\n";
  // rock
  o << i3 << "<Grid Name=\"rock\" GridType=\"Uniform\">\n"
    << i4 << "<Topology TopologyType=\"Tetrahedron\" NumberOfElements=\"" << M << "\">\n"
    << hdf_item(h5, tets_path, M, 4, true, i5) << i4 << "</Topology>\n"
    << geometry;
  if (f.u) o << attribute("u", "Vector", "Node", hdf_item(h5, gpath + "/u", N, 3, false, i5), i4);
  if (f.v) o << attribute("v", "Vector", "Node", hdf_item(h5, gpath + "/v", N, 3, false, i5), i4);
  if (f.stress) {
    o << attribute("stress", "Tensor6", "Cell", hdf_item(h5, gpath + "/stress", M, 6, false, i5), i4);
  }
  if (f.von_mises)
    o << attribute("von_mises", "Scalar", "Cell", hdf_item(h5, gpath + "/von_mises", M, 0, false, i5), i4);
  for (const TetField& e : f.extra)
    o << attribute(e.name, "Scalar", "Cell", hdf_item(h5, gpath + "/" + e.name, M, 0, false, i5), i4);
  o << i3 << "</Grid>\n";
  // cracks
  if (K > 0) {
    o << i3 << "<Grid Name=\"cracks\" GridType=\"Uniform\">\n"
      << i4 << "<Topology TopologyType=\"Triangle\" NumberOfElements=\"" << K << "\">\n"
      << hdf_item(h5, gpath + "/crack_faces", K, 3, true, i5) << i4 << "</Topology>\n"
      << geometry;
    if (f.crack_damage)
      o << attribute("D", "Scalar", "Cell", hdf_item(h5, gpath + "/crack_damage", K, 0, false, i5), i4);
    if (f.crack_mode) o << attribute("mode", "Scalar", "Cell", hdf_item(h5, gpath + "/crack_mode", K, 0, true, i5), i4);
    o << i3 << "</Grid>\n";
  }
  o << "    </Grid>\n";
  return o.str();
}

}  // namespace

// ---------------------------------------------------------------- FieldWriter

FieldWriter::FieldWriter(const std::string& folder, const std::string& basename) {
  namespace fs = std::filesystem;
  if (basename.empty() || basename.find('/') != std::string::npos)
    throw RunError("field output: base name '" + basename + "' must be a non-empty file name without '/'");
  const fs::path dir = folder.empty() ? fs::path(".") : fs::path(folder);
  h5_name_ = basename + ".h5";
  h5_path_ = (dir / h5_name_).string();
  xdmf_path_ = (dir / (basename + ".xdmf")).string();

  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw OutputError("field output: cannot create folder " + dir.string() + ": " +
                      (ec ? ec.message() : std::string("a file of that name is in the way")));

  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors are reported through OutputError instead
  Handle file(H5Fcreate(h5_path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) h5_fail(h5_path_, "creating the file");
  write_attr_string(file.get(), "writer", "fdem FieldWriter", h5_path_);
  if (!file.reset()) h5_fail(h5_path_, "closing the file");

  // An index from an earlier run would point at frames the fresh .h5 no longer has.
  fs::remove(xdmf_path_, ec);
  if (ec) throw OutputError("field output: cannot remove stale index " + xdmf_path_ + ": " + ec.message());
}

void FieldWriter::write(const FieldFrame& f) {
  validate_frame(f, h5_path_);
  const int index = frames();
  const bool first_mesh = !have_mesh_;
  const std::string tets_path = write_frame_group(f, h5_path_, index, first_mesh, first_mesh || mesh_tets_ != *f.tets);
  if (first_mesh) {
    mesh_tets_ = *f.tets;
    have_mesh_ = true;
  }
  grids_.push_back(xdmf_grid(f, h5_name_, index, tets_path));
  labels_.push_back(f.label);
  try {
    rewrite_index();
  } catch (...) {
    grids_.pop_back();
    labels_.pop_back();  // the frame group stays in the .h5 but is not indexed; the next write replaces it
    throw;
  }
}

void FieldWriter::relabel(int index, const std::string& label) {
  if (index < 0 || index >= frames()) throw RunError("field output: no frame " + std::to_string(index) + " to relabel");
  const std::string gname = frame_name(index);
  {
    Handle h5(H5Fopen(h5_path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
    if (!h5.ok()) h5_fail(h5_path_, "opening the file to relabel frame " + std::to_string(index));
    Handle g(H5Gopen2(h5.get(), gname.c_str(), H5P_DEFAULT), H5Gclose);
    if (!g.ok()) h5_fail(h5_path_, "opening group /" + gname);
    if (H5Aexists(g.get(), "label") > 0 && H5Adelete(g.get(), "label") < 0)
      h5_fail(h5_path_, "removing the label of /" + gname);
    write_attr_string(g.get(), "label", label, h5_path_);
  }
  // The grid's first line carries its name; an Information element its label.
  std::string& grid = grids_[index];
  const std::string old = grid;
  const std::size_t eol = grid.find('\n');
  const std::string name = label.empty() ? gname : gname + "_" + label;
  grid.replace(0, eol,
               "    <Grid Name=\"" + xml_escape(name) + "\" GridType=\"Collection\" CollectionType=\"Spatial\">");
  const std::string key = "<Information Name=\"label\" Value=\"";
  const std::size_t at = grid.find(key) + key.size();
  grid.replace(at, grid.find('"', at) - at, xml_escape(label));
  const std::string old_label = labels_[index];
  labels_[index] = label;
  try {
    rewrite_index();
  } catch (...) {
    grid = old;
    labels_[index] = old_label;
    throw;
  }
}

FieldWriter::FieldWriter(const std::string& folder, const std::string& basename, const FieldWriterState& state)
    : grids_(state.grids), labels_(state.labels) {
  namespace fs = std::filesystem;
  const fs::path dir = folder.empty() ? fs::path(".") : fs::path(folder);
  h5_name_ = basename + ".h5";
  h5_path_ = (dir / h5_name_).string();
  xdmf_path_ = (dir / (basename + ".xdmf")).string();
  mesh_tets_ = state.mesh_tets;
  have_mesh_ = state.have_mesh;
  if (labels_.size() != grids_.size()) throw OutputError("field output " + h5_path_ + ": inconsistent saved state");
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  try {
    take_over();
  } catch (const OutputError& first) {
    // A frame cut short (the disk filled while it was written) can leave the file so that its
    // group cannot be removed: the frames the checkpoint holds go into a new file instead.
    const std::string copied = copy_kept_frames();
    if (!copied.empty())
      throw OutputError(std::string(first.what()) + "; copying the " + std::to_string(frames()) +
                        " frames before the checkpoint into a new file failed too (" + copied +
                        "). Fix: run the scene afresh, without --restart (the field frames cannot be continued)");
    take_over();
    repaired_ = std::string(first.what()) + "; the " + std::to_string(frames()) +
                " frames before the checkpoint were copied into a new " + h5_name_;
  }
  rewrite_index();
}

void FieldWriter::take_over() {
  Handle h5(H5Fopen(h5_path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
  if (!h5.ok()) h5_fail(h5_path_, "opening the file of the interrupted run (restart in its output folder)");
  for (int i = 0; i < frames(); ++i) {
    const std::string gname = frame_name(i);
    Handle g(H5Gopen2(h5.get(), gname.c_str(), H5P_DEFAULT), H5Gclose);
    if (!g.ok()) h5_fail(h5_path_, "opening group /" + gname + " that the checkpoint says was written");
    if (H5Aexists(g.get(), "label") > 0 && H5Adelete(g.get(), "label") < 0)
      h5_fail(h5_path_, "removing the label of /" + gname);
    write_attr_string(g.get(), "label", labels_[i], h5_path_);
  }
  // Frames written after the checkpoint are written again by the continued run.
  for (int i = frames();; ++i) {
    const std::string gname = frame_name(i);
    if (H5Lexists(h5.get(), gname.c_str(), H5P_DEFAULT) <= 0) break;
    if (H5Ldelete(h5.get(), gname.c_str(), H5P_DEFAULT) < 0) h5_fail(h5_path_, "removing /" + gname);
  }
  if (!h5.reset()) h5_fail(h5_path_, "closing the file");
}

std::string FieldWriter::copy_kept_frames() const {
  namespace fs = std::filesystem;
  const std::string tmp = h5_path_ + ".copy";
  std::string why;
  {
    Handle from(H5Fopen(h5_path_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    Handle to(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!from.ok() || !to.ok()) why = (from.ok() ? "creating " + tmp : "opening " + h5_path_) + ": " + h5_detail();
    std::vector<std::string> names;
    if (have_mesh_) names.push_back("mesh");
    for (int i = 0; i < frames(); ++i) names.push_back(frame_name(i));
    for (const std::string& n : names)
      if (why.empty() && H5Ocopy(from.get(), n.c_str(), to.get(), n.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0)
        why = "copying /" + n + ": " + h5_detail();
    if (!to.reset() && why.empty()) why = "closing " + tmp + ": " + h5_detail();
  }
  std::error_code ec;
  if (why.empty()) fs::rename(tmp, h5_path_, ec);
  if (ec) why = "renaming " + tmp + ": " + ec.message();
  if (!why.empty()) fs::remove(tmp, ec);
  return why;
}

void FieldWriter::rewrite_index() const {
  std::string text =
      "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
      "<Xdmf xmlns:xi=\"http://www.w3.org/2001/XInclude\" Version=\"3.0\">\n"
      "  <Domain>\n"
      "  <Grid Name=\"fdem\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const std::string& g : grids_) text += g;
  text += "  </Grid>\n  </Domain>\n</Xdmf>\n";
  try {
    write_file_atomically(xdmf_path_, text);
  } catch (const OutputError& e) {
    throw OutputError(std::string("field output: index: ") + e.what());
  }
}

int open_hdf5_files() {
  return static_cast<int>(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_FILE));
}

}  // namespace fdem
