// HDF5 heavy data + XDMF 3 index for ParaView. See fields.hpp for the file layout.
#include "io/fields.hpp"

#include <hdf5.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>

#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"

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
  /// Closes the handle held, and holds `id`.
  void adopt(hid_t id) {
    reset();
    id_ = id;
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

/// Rows of one kind (nodes, tets or crack faces) in a file that several ranks may share: this
/// rank's, where they start in the file, and all of them.
struct Rows {
  hsize_t mine = 0, first = 0, all = 0;
};
enum RowKind { kNodeRows, kTetRows, kFaceRows };
using FrameRows = std::array<Rows, 3>;  // by RowKind

/// One dataset of a frame: its name, types and columns (0: rank 1), and this rank's rows.
struct Column {
  std::string name;
  hid_t file_type, mem_type;
  hsize_t cols;
  RowKind kind;
  const void* data;
  std::size_t row_bytes() const { return (cols == 0 ? 1 : cols) * H5Tget_size(mem_type); }
};

/// Writes a column's dataset at loc/name: all its rows (`xfer` the default), or this rank's
/// rows through MPI-IO (every rank calls, those without rows too: the dataset's creation is
/// collective). There a failed write of this rank's rows goes to `failed` (the first only), so
/// that the rank keeps making the collective calls the others make; the caller throws it.
void write_dataset(hid_t loc, const Column& c, const Rows& r, hid_t xfer, const std::string& file,
                   const std::string& where, std::string* failed = nullptr) {
  const int dims_n = c.cols == 0 ? 1 : 2;
  const hsize_t dims[2] = {r.all, c.cols}, start[2] = {r.first, 0}, count[2] = {r.mine, c.cols};
  Handle space(H5Screate_simple(dims_n, dims, nullptr), H5Sclose);
  if (!space.ok()) h5_fail(file, "creating the dataspace of " + where);
  Handle ds(H5Dcreate2(loc, c.name.c_str(), c.file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) h5_fail(file, "creating dataset " + where);
  if (xfer == H5P_DEFAULT) {  // this process writes all rows
    if (r.all > 0 && H5Dwrite(ds.get(), c.mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.data) < 0)
      h5_fail(file, "writing dataset " + where);
  } else {
    const hsize_t mem_dims[2] = {std::max<hsize_t>(r.mine, 1), c.cols};
    Handle mem(H5Screate_simple(dims_n, mem_dims, nullptr), H5Sclose);
    const herr_t selected = r.mine == 0
                                ? std::min(H5Sselect_none(mem.get()), H5Sselect_none(space.get()))
                                : H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
    static const double none = 0;  // (a rank without rows may hold no array)
    if (!mem.ok() || selected < 0 ||
        H5Dwrite(ds.get(), c.mem_type, mem.get(), space.get(), xfer, c.data ? c.data : &none) < 0) {
      try {
        h5_fail(file, "writing this rank's rows of dataset " + where);
      } catch (const OutputError& e) {
        if (!failed) throw;
        if (failed->empty()) *failed = e.what();
      }
    }
  }
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

/// A frame's datasets as this rank holds them: node ids shifted to the file's numbering, the
/// stress in VTK's order (xx, yy, zz, xy, yz, xz, so ParaView names the components right).
struct FrameData {
  std::vector<std::array<int, 4>> tets;
  std::vector<std::array<int, 3>> faces;
  std::vector<real> stress;
  Column topology;                          // the tets' node ids
  std::vector<Column> columns;              // the frame group's datasets, in order
  std::vector<std::vector<char>> gathered;  // gathered: every rank's rows of each column (rank 0)
};

FrameData frame_data(const FieldFrame& f, const FrameRows& rows) {
  FrameData d;
  const int shift = static_cast<int>(rows[kNodeRows].first);
  d.tets = *f.tets;
  for (auto& t : d.tets)
    for (int& n : t) n += shift;
  d.topology = {"tets", H5T_STD_I32LE, H5T_NATIVE_INT, 4, kTetRows, d.tets.data()};
  auto add = [&](const char* name, const void* data, hsize_t cols, RowKind kind) {
    d.columns.push_back({name, file_real(), mem_real(), cols, kind, data});
  };
  add("x", f.x->data(), 3, kNodeRows);
  if (f.u) add("u", f.u->data(), 3, kNodeRows);
  if (f.v) add("v", f.v->data(), 3, kNodeRows);
  if (f.stress) {
    d.stress.reserve(6 * f.stress->size());
    for (const Sym3& q : *f.stress) d.stress.insert(d.stress.end(), {q.xx, q.yy, q.zz, q.xy, q.yz, q.xz});
    add("stress", d.stress.data(), 6, kTetRows);
  }
  if (f.von_mises) add("von_mises", f.von_mises->data(), 0, kTetRows);
  for (const TetField& e : f.extra) add(e.name.c_str(), e.values->data(), 0, kTetRows);
  if (rows[kFaceRows].all > 0) {
    if (f.crack_faces) d.faces = *f.crack_faces;
    for (auto& t : d.faces)
      for (int& n : t) n += shift;
    d.columns.push_back({"crack_faces", H5T_STD_I32LE, H5T_NATIVE_INT, 3, kFaceRows, d.faces.data()});
    if (f.crack_damage) add("crack_damage", f.crack_damage->data(), 0, kFaceRows);
    if (f.crack_mode)
      d.columns.push_back({"crack_mode", H5T_STD_I32LE, H5T_NATIVE_INT, 0, kFaceRows, f.crack_mode->data()});
  }
  return d;
}

/// Gathered: rank 0 receives every rank's rows of each column, in rank order, and its columns
/// point at them. `counts`: each rank's rows by kind.
void gather_to_root(FrameData& d, const std::vector<std::array<long, 3>>& counts, MPI_Comm comm, int rank) {
  const int size = static_cast<int>(counts.size());
  std::vector<Column*> all{&d.topology};
  for (Column& c : d.columns) all.push_back(&c);
  for (Column* c : all) {
    // Counted in rows (an MPI type of one row), so that the counts fit an int.
    MPI_Datatype row;
    MPI_Type_contiguous(static_cast<int>(c->row_bytes()), MPI_BYTE, &row);
    MPI_Type_commit(&row);
    std::vector<int> rows(size), offsets(size + 1, 0);
    for (int r = 0; r < size; ++r) {
      rows[r] = static_cast<int>(counts[r][c->kind]);
      offsets[r + 1] = offsets[r] + rows[r];
    }
    std::vector<char>& buf = d.gathered.emplace_back(rank == 0 ? std::size_t(offsets[size]) * c->row_bytes() : 0);
    MPI_Gatherv(c->data, rows[rank], row, buf.data(), rows.data(), offsets.data(), row, 0, comm);
    MPI_Type_free(&row);
    c->data = buf.data();
  }
}

/// Frame `index` as an HDF5 group: its time, step and label, and its datasets. The first frame
/// also writes /mesh/tets; a later frame whose tets differ carries its own at `tets_path`.
/// `fapl` and `xfer`: the file access and transfer of a collective write, or the defaults.
void write_frame_group(const FieldFrame& f, const FrameData& d, const FrameRows& rows, const std::string& file,
                       hid_t fapl, hid_t xfer, int index, bool first_mesh, const std::string& tets_path) {
  const std::string gname = frame_name(index);
  const std::string gpath = "/" + gname;
  std::string failed;  // a failed write of this rank's rows, thrown once the collective calls are made
  Handle h5(H5Fopen(file.c_str(), H5F_ACC_RDWR, fapl), H5Fclose);
  if (!h5.ok()) h5_fail(file, "opening the file for frame " + std::to_string(index));
  // A frame group left behind by an earlier failed write() is replaced.
  if (H5Lexists(h5.get(), gname.c_str(), H5P_DEFAULT) > 0 && H5Ldelete(h5.get(), gname.c_str(), H5P_DEFAULT) < 0)
    h5_fail(file, "removing the incomplete group " + gpath);
  if (first_mesh) {
    if (H5Lexists(h5.get(), "mesh", H5P_DEFAULT) > 0 && H5Ldelete(h5.get(), "mesh", H5P_DEFAULT) < 0)
      h5_fail(file, "removing an incomplete /mesh");
    Handle mesh(H5Gcreate2(h5.get(), "mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    if (!mesh.ok()) h5_fail(file, "creating group /mesh");
    write_dataset(mesh.get(), d.topology, rows[kTetRows], xfer, file, "/mesh/tets", &failed);
  }
  Handle g(H5Gcreate2(h5.get(), gname.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.ok()) h5_fail(file, "creating group " + gpath);
  write_attr_real(g.get(), "time", f.time, file);
  write_attr_long(g.get(), "step", f.step, file);
  write_attr_string(g.get(), "label", f.label, file);
  if (tets_path != "/mesh/tets")  // topology changed: this frame carries its own connectivity
    write_dataset(g.get(), d.topology, rows[kTetRows], xfer, file, tets_path, &failed);
  for (const Column& c : d.columns) write_dataset(g.get(), c, rows[c.kind], xfer, file, gpath + "/" + c.name, &failed);
  if (!g.reset()) h5_fail(file, "closing group " + gpath);
  // (Through MPI-IO a flush is an fsync on every rank. The close writes the same data, and a
  // checkpoint syncs the file itself.)
  if (xfer == H5P_DEFAULT && H5Fflush(h5.get(), H5F_SCOPE_GLOBAL) < 0)
    h5_fail(file, "flushing frame " + std::to_string(index));
  if (!h5.reset()) h5_fail(file, "closing the file after frame " + std::to_string(index));
  if (!failed.empty()) throw OutputError(failed);
}

/// The frame's XDMF grid: the rock tets with their fields, and the crack faces if any.
std::string xdmf_grid(const FieldFrame& f, const FrameRows& rows, const std::string& h5, int index,
                      const std::string& tets_path) {
  const std::string gname = frame_name(index);
  const std::string gpath = "/" + gname;
  const std::size_t N = rows[kNodeRows].all, M = rows[kTetRows].all, K = rows[kFaceRows].all;
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

/// File access and transfer properties: MPI-IO over `ranks`, or the defaults (this process
/// alone, or rank 0 writing what it gathered). The metadata is read and written collectively.
/// Each rank's rows of a dataset are one contiguous block, so it writes them on its own
/// (independent transfer): measured 1.5-2x faster than a collective transfer (bench_fields).
class Access {
 public:
  Access(MPI_Comm ranks, bool collective, const std::string& file) {
    if (!collective) return;
#ifdef H5_HAVE_PARALLEL
    fapl_.adopt(H5Pcreate(H5P_FILE_ACCESS));
    xfer_.adopt(H5Pcreate(H5P_DATASET_XFER));
    if (!fapl_.ok() || !xfer_.ok() || H5Pset_fapl_mpio(fapl_.get(), ranks, MPI_INFO_NULL) < 0 ||
        H5Pset_all_coll_metadata_ops(fapl_.get(), true) < 0 || H5Pset_coll_metadata_write(fapl_.get(), true) < 0 ||
        H5Pset_dxpl_mpio(xfer_.get(), H5FD_MPIO_INDEPENDENT) < 0)
      h5_fail(file, "setting up MPI-IO");
#else
    (void)ranks;
    throw OutputError("field output " + file + ": this fdem's HDF5 has no MPI-IO for a collective write");
#endif
  }
  hid_t fapl() const {
    return fapl_.ok() ? fapl_.get() : H5P_DEFAULT;
  }
  hid_t xfer() const {
    return xfer_.ok() ? xfer_.get() : H5P_DEFAULT;
  }

 private:
  Handle fapl_{-1, H5Pclose}, xfer_{-1, H5Pclose};
};

/// Several ranks: every rank must give the same datasets, or their collective calls would not
/// match. Throws RunError on every rank where they differ.
void check_same_columns(const FrameData& d, MPI_Comm ranks, const std::string& file) {
  std::string names;
  for (const Column& c : d.columns) names += c.name + "/" + std::to_string(c.cols) + "/" + std::to_string(c.kind) + ";";
  const std::uint64_t mine = fnv1a64(names.data(), names.size());
  std::uint64_t low = mine, high = mine;
  MPI_Allreduce(MPI_IN_PLACE, &low, 1, MPI_UINT64_T, MPI_MIN, ranks);
  MPI_Allreduce(MPI_IN_PLACE, &high, 1, MPI_UINT64_T, MPI_MAX, ranks);
  if (low != high)
    throw RunError("field output " + file + ": the ranks give different fields (this rank: " + names +
                   "); every rank must give the same arrays and extra fields");
}

/// This rank's rows of each kind in the file; `counts` gets every rank's (in rank order).
FrameRows frame_rows(const FieldFrame& f, MPI_Comm ranks, int rank, int size,
                     std::vector<std::array<long, 3>>& counts) {
  const std::array<long, 3> mine = {long(f.x->size()), long(f.tets->size()),
                                    f.crack_faces ? long(f.crack_faces->size()) : 0L};
  counts.assign(size, mine);
  if (size > 1) MPI_Allgather(mine.data(), 3, MPI_LONG, counts.data(), 3, MPI_LONG, ranks);
  FrameRows rows;
  for (int k = 0; k < 3; ++k) {
    rows[k].mine = hsize_t(mine[k]);
    for (int r = 0; r < size; ++r) {
      if (r < rank) rows[k].first += hsize_t(counts[r][k]);
      rows[k].all += hsize_t(counts[r][k]);
    }
  }
  return rows;
}

}  // namespace

// ---------------------------------------------------------------- FieldWriter

SharedWrite default_shared_write() {
#ifdef H5_HAVE_PARALLEL
  return SharedWrite::collective;
#else
  return SharedWrite::gathered;
#endif
}

void FieldWriter::share(MPI_Comm ranks, SharedWrite how) {
  ranks_ = ranks;
  how_ = how;
  if (ranks == MPI_COMM_NULL) return;
  MPI_Comm_rank(ranks, &rank_);
  MPI_Comm_size(ranks, &size_);
#ifndef H5_HAVE_PARALLEL
  how_ = SharedWrite::gathered;
#endif
}

template <class Work>
void FieldWriter::agree(Work&& work, bool everywhere) const {
  if (!shared()) {
    work();
    return;
  }
  int kind = 0;  // 1 RunError, 2 OutputError, 3 another
  std::string why;
  try {
    if (everywhere || rank_ == 0) work();
  } catch (const RunError& e) {
    kind = 1, why = e.what();
  } catch (const OutputError& e) {
    kind = 2, why = e.what();
  } catch (const std::exception& e) {
    kind = 3, why = e.what();
  }
  int first = kind ? rank_ : size_;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, ranks_);
  if (first == size_) return;
  int head[2] = {kind, static_cast<int>(why.size())};
  MPI_Bcast(head, 2, MPI_INT, first, ranks_);
  why.resize(head[1]);
  MPI_Bcast(why.data(), head[1], MPI_CHAR, first, ranks_);
  why = "rank " + std::to_string(first) + ": " + why;
  if (head[0] == 1) throw RunError(why);
  if (head[0] == 2) throw OutputError(why);
  throw std::runtime_error(why);
}

FieldWriter::FieldWriter(const std::string& folder, const std::string& basename, MPI_Comm ranks, SharedWrite how) {
  namespace fs = std::filesystem;
  share(ranks, how);
  if (basename.empty() || basename.find('/') != std::string::npos)
    throw RunError("field output: base name '" + basename + "' must be a non-empty file name without '/'");
  const fs::path dir = folder.empty() ? fs::path(".") : fs::path(folder);
  h5_name_ = basename + ".h5";
  h5_path_ = (dir / h5_name_).string();
  xdmf_path_ = (dir / (basename + ".xdmf")).string();
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors are reported through OutputError instead
  agree(
      [&] {
        std::error_code ec;
        fs::create_directories(dir, ec);
        if (ec || !fs::is_directory(dir))
          throw OutputError("field output: cannot create folder " + dir.string() + ": " +
                            (ec ? ec.message() : std::string("a file of that name is in the way")));
        // An index from an earlier run would point at frames the fresh .h5 no longer has.
        fs::remove(xdmf_path_, ec);
        if (ec) throw OutputError("field output: cannot remove stale index " + xdmf_path_ + ": " + ec.message());
      },
      false);
  agree(
      [&] {
        const Access access(ranks_, collective(), h5_path_);
        Handle file(H5Fcreate(h5_path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, access.fapl()), H5Fclose);
        if (!file.ok()) h5_fail(h5_path_, "creating the file");
        write_attr_string(file.get(), "writer", "fdem FieldWriter", h5_path_);
        if (!file.reset()) h5_fail(h5_path_, "closing the file");
      },
      collective());
}

void FieldWriter::write(const FieldFrame& f) {
  agree([&] { validate_frame(f, h5_path_); }, true);  // every rank's checks before any file is touched
  std::vector<std::array<long, 3>> counts;
  const FrameRows rows = frame_rows(f, ranks_, rank_, size_, counts);
  if (rows[kNodeRows].all > hsize_t(std::numeric_limits<int>::max()))
    throw RunError("field output " + h5_path_ + ": " + std::to_string(rows[kNodeRows].all) +
                   " nodes in a frame, more than its 32-bit node ids can number");
  FrameData data = frame_data(f, rows);
  if (shared()) check_same_columns(data, ranks_, h5_path_);
  const int index = frames();
  const bool first_mesh = !have_mesh_;
  // (Compared in the file's numbering: a rank before this one may have changed its node count.)
  int changed = first_mesh || mesh_tets_ != data.tets;
  if (shared()) MPI_Allreduce(MPI_IN_PLACE, &changed, 1, MPI_INT, MPI_MAX, ranks_);
  const std::string tets_path = changed && !first_mesh ? "/" + frame_name(index) + "/tets" : "/mesh/tets";
  FrameRows written = rows;  // the rows this process writes
  if (shared() && !collective()) {
    gather_to_root(data, counts, ranks_, rank_);
    for (Rows& r : written) r = {r.all, 0, r.all};
  }
  agree(
      [&] {
        const Access access(ranks_, collective(), h5_path_);
        write_frame_group(f, data, written, h5_path_, access.fapl(), access.xfer(), index, first_mesh, tets_path);
      },
      collective());
  if (first_mesh) {
    mesh_tets_ = data.tets;
    have_mesh_ = true;
  }
  grids_.push_back(xdmf_grid(f, rows, h5_name_, index, tets_path));
  labels_.push_back(f.label);
  try {
    agree([&] { rewrite_index(); }, false);
  } catch (...) {
    grids_.pop_back();
    labels_.pop_back();  // the frame group stays in the .h5 but is not indexed; the next write replaces it
    throw;
  }
}

void FieldWriter::relabel(int index, const std::string& label) {
  if (index < 0 || index >= frames()) throw RunError("field output: no frame " + std::to_string(index) + " to relabel");
  const std::string gname = frame_name(index);
  agree(
      [&] {
        const Access access(ranks_, collective(), h5_path_);
        Handle h5(H5Fopen(h5_path_.c_str(), H5F_ACC_RDWR, access.fapl()), H5Fclose);
        if (!h5.ok()) h5_fail(h5_path_, "opening the file to relabel frame " + std::to_string(index));
        Handle g(H5Gopen2(h5.get(), gname.c_str(), H5P_DEFAULT), H5Gclose);
        if (!g.ok()) h5_fail(h5_path_, "opening group /" + gname);
        if (H5Aexists(g.get(), "label") > 0 && H5Adelete(g.get(), "label") < 0)
          h5_fail(h5_path_, "removing the label of /" + gname);
        write_attr_string(g.get(), "label", label, h5_path_);
      },
      collective());
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
    agree([&] { rewrite_index(); }, false);
  } catch (...) {
    grid = old;
    labels_[index] = old_label;
    throw;
  }
}

FieldWriter::FieldWriter(const std::string& folder, const std::string& basename, const FieldWriterState& state,
                         MPI_Comm ranks, SharedWrite how)
    : grids_(state.grids), labels_(state.labels) {
  namespace fs = std::filesystem;
  share(ranks, how);
  const fs::path dir = folder.empty() ? fs::path(".") : fs::path(folder);
  h5_name_ = basename + ".h5";
  h5_path_ = (dir / h5_name_).string();
  xdmf_path_ = (dir / (basename + ".xdmf")).string();
  mesh_tets_ = state.mesh_tets;
  have_mesh_ = state.have_mesh;
  agree(
      [&] {
        if (labels_.size() != grids_.size())
          throw OutputError("field output " + h5_path_ + ": inconsistent saved state");
      },
      true);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  try {
    agree([&] { take_over(); }, collective());
  } catch (const OutputError& first) {
    // A frame cut short (the disk filled while it was written) can leave the file so that its
    // group cannot be removed: the frames the checkpoint holds go into a new file instead (rank
    // 0 alone, through the default file access).
    agree(
        [&] {
          const std::string copied = copy_kept_frames();
          if (!copied.empty())
            throw OutputError(std::string(first.what()) + "; copying the " + std::to_string(frames()) +
                              " frames before the checkpoint into a new file failed too (" + copied +
                              "). Fix: run the scene afresh, without --restart (the field frames cannot be continued)");
        },
        false);
    agree([&] { take_over(); }, collective());
    repaired_ = std::string(first.what()) + "; the " + std::to_string(frames()) +
                " frames before the checkpoint were copied into a new " + h5_name_;
  }
  agree([&] { rewrite_index(); }, false);
}

void FieldWriter::take_over() {
  const Access access(ranks_, collective(), h5_path_);
  Handle h5(H5Fopen(h5_path_.c_str(), H5F_ACC_RDWR, access.fapl()), H5Fclose);
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
