// The physical groups of a .msh file (io/msh_groups.hpp).
#include "io/msh_groups.hpp"

#include <algorithm>

namespace fdem::mesh_detail {

std::vector<int> PhysicalGroups::physicals(int dim, std::int64_t e) const {
  if (entity_is_physical) return e != 0 ? std::vector<int>{static_cast<int>(e)} : std::vector<int>{};
  const auto it = of_entity[dim].find(e);
  return it == of_entity[dim].end() ? std::vector<int>{} : it->second;
}

void read_physical_names(Reader& r, PhysicalGroups& g) {
  std::vector<std::string_view> tok;
  Reader::split(r.need("inside $PhysicalNames"), tok);
  const long header = r.line_no();
  if (tok.size() != 1)
    r.fail("expected the number of physical names on this line, found " + std::to_string(tok.size()) + " values",
           "write the count alone on the line after $PhysicalNames, or re-export the mesh");
  const std::uint64_t n = r.count(tok[0], "the number of physical names");
  for (std::uint64_t k = 0; k < n; ++k) {
    const std::string_view l = data_line(r, "$PhysicalNames", k, n, "names", header);
    Reader::split(l, tok);
    const std::size_t open = l.find('"'), close = l.rfind('"');
    if (tok.size() < 3 || open == std::string_view::npos || close <= open)
      r.fail("a physical name line needs: dimension tag \"name\", found " + quote(l),
             "fix this line or re-export the mesh from gmsh");
    const std::uint64_t dim = r.u64(tok[0], "the group's dimension");
    const std::int64_t tag = r.i64(tok[1], "the group's tag");
    if (dim > 3)
      r.fail("group dimension " + std::to_string(dim) + " is not 0 to 3", "fix this line or re-export the mesh");
    const std::string name(l.substr(open + 1, close - open - 1));
    if (!g.names.emplace(std::make_pair(int(dim), int(tag)), name).second)
      r.fail("physical group " + std::to_string(tag) + " of dimension " + std::to_string(dim) + " is named twice",
             "give each group one name and export again");
  }
  expect_end(r, "$EndPhysicalNames", std::to_string(n) + " physical names", header);
}

void read_entities(Reader& r, PhysicalGroups& g) {
  std::vector<std::string_view> tok;
  Reader::split(r.need("inside $Entities"), tok);
  const long header = r.line_no();
  if (tok.size() != 4)
    r.fail("expected 4 values (numPoints numCurves numSurfaces numVolumes), found " + std::to_string(tok.size()),
           "fix this line or re-export the mesh as version 4.1");
  std::uint64_t total = 0;
  for (int dim = 0; dim < 4; ++dim) {
    const std::uint64_t n = r.count(tok[dim], "the number of entities");
    total += n;
    for (std::uint64_t k = 0; k < n; ++k) {
      std::vector<std::string_view> e;
      Reader::split(data_line(r, "$Entities", k, n, "entities of a dimension", header), e);
      // A point: tag x y z; the others: tag and a bounding box. Then the physical tags' count.
      const std::size_t at = dim == 0 ? 4 : 7;
      const std::uint64_t m = e.size() > at ? r.u64(e[at], "the number of physical tags") : 0;
      if (e.size() <= at || m > e.size() - at - 1)
        r.fail("an entity of dimension " + std::to_string(dim) + " needs its tag, " +
                   (dim == 0 ? "x y z" : "a bounding box") + " and its physical tags; found " +
                   std::to_string(e.size()) + " values",
               "fix this line or re-export the mesh as version 4.1");
      const std::int64_t entity = r.i64(e[0], "the entity tag");
      std::vector<int>& phys = g.of_entity[dim][entity];
      for (std::uint64_t i = 0; i < m; ++i) phys.push_back(static_cast<int>(r.i64(e[at + 1 + i], "a physical tag")));
    }
  }
  expect_end(r, "$EndEntities", std::to_string(total) + " entities", header);
}

std::vector<std::pair<std::size_t, std::int64_t>> merge_repeated_tets(std::vector<RawTet>& tets) {
  std::vector<std::pair<std::size_t, std::int64_t>> extra;
  const bool one_entity =
      std::all_of(tets.begin(), tets.end(), [&](const RawTet& t) { return t.entity == tets.front().entity; });
  if (one_entity) return extra;  // then no tet can be written twice
  using Key = std::array<std::uint64_t, 4>;
  std::vector<std::pair<Key, std::size_t>> keys(tets.size());
  for (std::size_t t = 0; t < tets.size(); ++t) {
    Key k{tets[t].node[0], tets[t].node[1], tets[t].node[2], tets[t].node[3]};
    std::sort(k.begin(), k.end());
    keys[t] = {k, t};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<std::size_t> first(tets.size());  // each tet's first copy in file order
  for (std::size_t i = 0; i < keys.size(); ++i)
    first[keys[i].second] = (i > 0 && keys[i].first == keys[i - 1].first) ? first[keys[i - 1].second] : keys[i].second;
  std::vector<std::size_t> kept_index(tets.size());
  std::size_t kept = 0;
  std::vector<std::pair<std::size_t, std::int64_t>> dropped;  // (first copy, entity)
  for (std::size_t t = 0; t < tets.size(); ++t) {
    if (first[t] != t) {
      dropped.push_back({first[t], tets[t].entity});
      continue;
    }
    kept_index[t] = kept;
    tets[kept++] = tets[t];
  }
  tets.resize(kept);
  for (const auto& [t, e] : dropped) extra.push_back({kept_index[t], e});
  return extra;
}

std::vector<MeshGroup> assemble_groups(const Reader& r, const PhysicalGroups& g, const std::vector<RawTet>& tets,
                                       const std::vector<std::pair<std::size_t, std::int64_t>>& extra,
                                       const std::vector<RawFace>& faces,
                                       const std::function<int(std::uint64_t, long)>& vertex_of, const Mesh& mesh) {
  std::map<std::pair<int, int>, MeshGroup> by_key;  // (-dim, tag): volumes first
  auto group = [&](int dim, int tag) -> MeshGroup& {
    MeshGroup& m = by_key[{-dim, tag}];
    m.dim = dim, m.tag = tag;
    return m;
  };
  for (const auto& [key, name] : g.names)
    if (key.first >= 2) group(key.first, key.second).name = name;  // a named group may be empty
  for (std::size_t t = 0; t < tets.size(); ++t)
    for (const int p : g.physicals(3, tets[t].entity)) group(3, p).tets.push_back(static_cast<int>(t));
  for (const auto& [t, e] : extra)
    for (const int p : g.physicals(3, e)) group(3, p).tets.push_back(static_cast<int>(t));
  std::vector<TetFace> of_tets;  // (made at the first surface triangle)
  for (const RawFace& f : faces) {
    const std::vector<int> phys = g.physicals(2, f.entity);
    if (phys.empty()) continue;
    if (of_tets.empty()) of_tets = sorted_tet_faces(mesh);
    TetFace v{{}, {vertex_of(f.node[0], f.line), vertex_of(f.node[1], f.line), vertex_of(f.node[2], f.line)}};
    v.key = v.face;
    std::sort(v.key.begin(), v.key.end());
    if (!std::binary_search(of_tets.begin(), of_tets.end(), v))
      r.fail_at(f.line,
                "triangle (element tag " + std::to_string(f.tag) + ") of " + group(2, phys[0]).label() +
                    " is not a face of any tetrahedron: the surface does not conform to the volume mesh",
                "embed the surface in the volume (gmsh: Surface{...} In Volume{...}) and mesh again");
    for (const int p : phys) group(2, p).faces.push_back(v.face);
  }
  std::vector<MeshGroup> out;
  for (auto& [key, m] : by_key) {
    std::sort(m.tets.begin(), m.tets.end());
    m.tets.erase(std::unique(m.tets.begin(), m.tets.end()), m.tets.end());
    out.push_back(std::move(m));
  }
  check_group_names(r.path(), out);
  return out;
}

}  // namespace fdem::mesh_detail
