// gmsh_session.cpp — Gmsh's one global session: initialised once, used under a lock, its messages
// captured, reset after a failure (io/gmsh_session.h); and the .msh reader's Gmsh side. With the
// fill in src/meshing/fill_gmsh.cpp, the only files that include gmsh.h (built with
// PALPATE_WITH_GMSH; gmsh_none.cpp replaces this file without it).
#include "io/gmsh_session.h"

#include <gmsh.h>

#include <fmt/format.h>

#include <algorithm>
#include <exception>
#include <mutex>
#include <new>
#include <numeric>
#include <unordered_map>
#include <vector>

namespace palpate::io {

namespace {

// Gmsh keeps one global model and option set: every use goes through this lock.
std::mutex& gmsh_mutex() {
  static std::mutex m;
  return m;
}

// Called with the lock held. Initialises Gmsh once, silent, and with errors logged rather than
// thrown: an exception thrown from inside Gmsh's readers leaves it "busy" for every later call.
bool gmsh_initialised = false;  // guarded by gmsh_mutex()

void ensure_gmsh() {
  bool& initialised = gmsh_initialised;
  if (initialised) return;
  gmsh::initialize(0, nullptr, false);
  gmsh::option::setNumber("General.Terminal", 0);
  gmsh::option::setNumber("General.AbortOnError", 0);
  gmsh::option::setNumber("General.Verbosity", 2);  // errors and warnings only
  initialised = true;
}

}  // namespace

std::string run_gmsh(const std::function<void()>& work) {
  std::lock_guard lock(gmsh_mutex());
  ensure_gmsh();
  std::string failure;
  bool thrown = true;
  gmsh::logger::start();
  try {
    gmsh::clear();
    work();
    thrown = false;
  } catch (const std::bad_alloc&) {
    failure = "out of memory (does the file promise more nodes or elements than it holds?)";
  } catch (const std::exception& e) {
    failure = e.what();
  } catch (const std::string& s) {
    failure = s;
  } catch (...) {
    failure = "unknown Gmsh failure";
  }
  std::vector<std::string> log;
  gmsh::logger::get(log);
  gmsh::logger::stop();
  std::string errors;
  for (const std::string& line : log)
    if (line.rfind("Error: ", 0) == 0) {
      if (!errors.empty()) errors += "; ";
      errors += line.substr(7);
    }
  if (!failure.empty()) errors += (errors.empty() ? "" : "; ") + failure;
  if (thrown) {
    // An exception out of Gmsh's reader leaves it marked busy ("I'm busy! Ask me that later")
    // for every later call: only finalising and initialising again clears that.
    gmsh::finalize();
    gmsh_initialised = false;
  } else {
    gmsh::clear();  // leave no model behind holding memory
  }
  return errors;
}

Result<TetMesh> current_tets(const std::string& where) {
  std::vector<std::size_t> node_tags;
  std::vector<double> coords, params;
  gmsh::model::mesh::getNodes(node_tags, coords, params, -1, -1, false, false);
  std::vector<std::size_t> order(node_tags.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return node_tags[a] < node_tags[b]; });
  TetMesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(node_tags.size()), 3);
  std::unordered_map<std::size_t, int> index_of;
  index_of.reserve(node_tags.size());
  for (size_t i = 0; i < order.size(); ++i) {
    const size_t j = order[i];
    if (!index_of.emplace(node_tags[j], static_cast<int>(i)).second)
      return Error{fmt::format("{}: node tag {} appears twice", where, node_tags[j])};
    for (int k = 0; k < 3; ++k) mesh.V(static_cast<Eigen::Index>(i), k) = coords[3 * j + k];
  }

  std::vector<std::size_t> elem_tags, elem_nodes;
  gmsh::model::mesh::getElementsByType(kGmshTetrahedron, elem_tags, elem_nodes, -1);
  if (elem_nodes.size() != 4 * elem_tags.size())
    return Error{fmt::format("{}: Gmsh returned {} nodes for {} tetrahedra", where, elem_nodes.size(), elem_tags.size())};
  std::vector<std::size_t> by_tag(elem_tags.size());
  std::iota(by_tag.begin(), by_tag.end(), size_t{0});
  std::stable_sort(by_tag.begin(), by_tag.end(), [&](size_t a, size_t b) { return elem_tags[a] < elem_tags[b]; });
  mesh.T.resize(static_cast<Eigen::Index>(elem_tags.size()), 4);
  for (size_t r = 0; r < by_tag.size(); ++r) {
    const size_t e = by_tag[r];
    for (int k = 0; k < 4; ++k) {
      const auto it = index_of.find(elem_nodes[4 * e + k]);
      if (it == index_of.end())
        return Error{fmt::format("{}: tetrahedron {} (element tag {}) refers to node {}, which is not defined", where,
                                 r, elem_tags[e], elem_nodes[4 * e + k])};
      mesh.T(static_cast<Eigen::Index>(r), k) = it->second;
    }
  }
  return mesh;
}

Result<TetMesh> gmsh_read_tets(const std::filesystem::path& file) {
  const std::string where = file.string();
  Result<TetMesh> mesh = Error{""};
  const std::string errors = run_gmsh([&] {
    gmsh::open(where);
    mesh = current_tets(where);
  });
  if (!errors.empty()) return Error{fmt::format("{}: Gmsh could not read the mesh: {}", where, errors)};
  return mesh;
}

}  // namespace palpate::io
