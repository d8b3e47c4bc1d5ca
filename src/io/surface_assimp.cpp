// surface_assimp.cpp — load_surface: OBJ, STL, PLY, OFF (and any other format assimp reads) into a
// merged, validated SurfaceMesh. The only file of palpate that includes assimp's headers.
#include <palpate/mesh.h>

#include "core/mesh_topology.h"
#include "io/mesh_io.h"
#include "io/text_lines.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <iterator>
#include <cstring>
#include <fstream>
#include <system_error>
#include <unordered_map>
#include <vector>

namespace palpate {

namespace {

// Vertices are merged by exact position across all meshes of the scene, so a surface whose
// corners carry different normals or UVs, or that a file splits into groups, stays connected.
struct PositionHash {
  size_t operator()(const std::array<float, 3>& p) const {
    size_t h = 0;
    for (float x : p) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, &x, sizeof bits);
      h = h * 1000003u ^ bits;
    }
    return h;
  }
};

// Bytes of a PLY scalar type; 0 for an unknown name.
size_t ply_type_size(std::string_view t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// assimp 5.2's PLY reader loops forever on a header without "end_header", and trusts the header's
// element counts (a 318-byte cube claiming 100,000,000 vertices ran for a minute and 1.3 GB;
// claiming fewer, it "read" vertices the file does not have): check the header ourselves, and
// every count against what the file holds after it, before handing the file over (as the OFF and
// Gmsh readers do). Each element needs at least one number per property (a list, its count)
// in ASCII, and at least its properties' bytes (a list, its count's) in binary.
Status check_ply_header(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string line;
  int number = 0;
  const auto trimmed = [&line] {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    return line;
  };
  struct Element {
    std::string name;
    unsigned long long count = 0;
    size_t numbers = 0, bytes = 0;  // at least, per element
    int line = 0;
  };
  std::vector<Element> elements;
  bool ascii = false;
  const std::string name = file.string();
  while (std::getline(in, line)) {
    ++number;
    if (number == 1 && trimmed() != "ply") return Error{fmt::format("{}:1: expected the PLY magic line 'ply'", name)};
    const std::string l = trimmed();
    std::string_view tok[6];
    size_t n = 0;
    for (size_t i = 0; i < l.size() && n < 6;) {
      while (i < l.size() && (l[i] == ' ' || l[i] == '\t')) ++i;
      const size_t start = i;
      while (i < l.size() && l[i] != ' ' && l[i] != '\t') ++i;
      if (i > start) tok[n++] = std::string_view(l).substr(start, i - start);
    }
    if (n >= 2 && tok[0] == "format") ascii = tok[1] == "ascii";
    if (n >= 3 && tok[0] == "element") {
      long long count = 0;
      if (!io::parse_int(tok[2], count) || count < 0)
        return Error{fmt::format("{}:{}: element {}: expected a count >= 0, found '{}'", name, number,
                                 io::printable(tok[1]), io::printable(tok[2]))};
      elements.push_back({std::string(tok[1]), static_cast<unsigned long long>(count), 0, 0, number});
    }
    if (n >= 3 && tok[0] == "property" && !elements.empty()) {
      Element& e = elements.back();
      e.numbers += 1;
      e.bytes += tok[1] == "list" ? (n >= 3 ? ply_type_size(tok[2]) : 0) : ply_type_size(tok[1]);
    }
    if (l == "end_header") {
      // What follows the header: numbers (ASCII) or bytes (binary).
      unsigned long long have = 0;
      if (ascii) {
        bool in_token = false;
        for (std::istreambuf_iterator<char> it(in), end; it != end; ++it) {
          const char c = *it;
          const bool space = c == ' ' || c == '\t' || c == '\n' || c == '\r';
          if (!space && !in_token) ++have;
          in_token = !space;
        }
      } else {
        const std::streamoff at = in.tellg();
        in.seekg(0, std::ios::end);
        have = static_cast<unsigned long long>(std::max<std::streamoff>(0, in.tellg() - at));
      }
      unsigned long long need = 0;
      for (const Element& e : elements) {
        const size_t each = std::max<size_t>(1, ascii ? e.numbers : e.bytes);
        if (e.count > (have - std::min(have, need)) / each)
          return Error{fmt::format("{}:{}: element {} claims {} but the file holds data for at most {} ({} {} after "
                                   "the header)", name, e.line, e.name, e.count,
                                   (have - std::min(have, need)) / each, have, ascii ? "numbers" : "bytes")};
        need += e.count * each;
      }
      return {};
    }
  }
  return Error{fmt::format("{}:{}: unexpected end of file, expected 'end_header' to close the PLY header",
                           name, number)};
}

// assimp 5.2's OFF reader silently clamps an out-of-range vertex index to the last vertex, which
// would turn a broken face into a wrong one: check the face lines ourselves first.
Status check_off_indices(const std::filesystem::path& file) {
  Result<std::string> text = io::read_whole_file(file);
  if (!text) return text.error();
  const std::string name = file.string();
  io::TokenReader in(*text, '#');
  constexpr size_t kMax = 64;
  std::string_view tok[kMax];
  size_t count = 0, total = 0;
  const auto error = [&](const std::string& what) { return Error{fmt::format("{}:{}: {}", name, in.line(), what)}; };
  if (!in.line_tokens(tok, kMax, count, total) || tok[0].size() < 3 || tok[0].substr(tok[0].size() - 3) != "OFF")
    return error("expected the OFF header line 'OFF'");
  if (tok[0] != "OFF" && tok[0] != "COFF" && tok[0] != "NOFF" && tok[0] != "CNOFF" && tok[0] != "STOFF")
    return {};  // 4OFF, nOFF and other variants: left to assimp
  size_t first = 1;
  if (count == 1) {
    if (!in.line_tokens(tok, kMax, count, total)) return error("unexpected end of file, expected '<vertices> <faces> <edges>'");
    first = 0;
  }
  long long nv = 0, nf = 0;
  if (count < first + 2 || !io::parse_int(tok[first], nv) || !io::parse_int(tok[first + 1], nf) || nv < 0 || nf < 0)
    return error("expected the counts '<vertices> <faces> <edges>'");
  for (long long v = 0; v < nv; ++v)
    if (!in.line_tokens(tok, kMax, count, total))
      return error(fmt::format("unexpected end of file, expected vertex {} of {}", v, nv));
  for (long long f = 0; f < nf; ++f) {
    if (!in.line_tokens(tok, kMax, count, total))
      return error(fmt::format("unexpected end of file, expected face {} of {}", f, nf));
    long long k = 0;
    if (!io::parse_int(tok[0], k) || k < 3 || static_cast<size_t>(k) + 1 > total)
      return error(fmt::format("face {}: expected '<n> <n vertex indices>' with n >= 3", f));
    for (long long j = 1; j <= k && static_cast<size_t>(j) < count; ++j) {
      long long idx = 0;
      if (!io::parse_int(tok[j], idx))
        return error(fmt::format("face {}: expected a vertex index, found '{}'", f, io::printable(tok[j])));
      if (idx < 0 || idx >= nv)
        return error(fmt::format("face {} has vertex index {} out of range [0, {})", f, idx, nv));
    }
  }
  return {};
}

// The files assimp may open for a mesh: the mesh itself, and files it names (an OBJ's mtllib)
// only when they are regular files in the mesh's own directory. An `mtllib` naming a FIFO blocked
// `palpate info` forever; /dev/zero was read without end; a path elsewhere is not the mesh's.
// Refused ones are "not found" to assimp, which then goes on without materials (never used).
class MeshDirectoryIO final : public Assimp::DefaultIOSystem {
 public:
  explicit MeshDirectoryIO(const std::filesystem::path& mesh) {
    std::error_code ec;
    mesh_ = std::filesystem::weakly_canonical(mesh, ec);
    if (ec) mesh_ = std::filesystem::absolute(mesh, ec);
  }
  bool Exists(const char* file) const override { return allowed(file) && DefaultIOSystem::Exists(file); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    return allowed(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
  }

 private:
  bool allowed(const char* file) const {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path p(file ? file : "");
    if (!fs::is_regular_file(p, ec)) return false;  // follows links: a link to /dev/zero is refused
    const fs::path c = fs::weakly_canonical(p, ec);
    if (ec) return false;
    return c == mesh_ || c.parent_path() == mesh_.parent_path();
  }
  std::filesystem::path mesh_;
};

}  // namespace

Result<SurfaceMesh> load_surface(const std::filesystem::path& file, double scale, const SurfaceRequirements& need) {
  const std::string where = file.string();
  if (Status s = io::check_scale(scale, where); !s) return s.error();
  if (Status s = io::check_readable(file); !s) return s.error();
  std::error_code ec;
  if (std::filesystem::file_size(file, ec) == 0 && !ec) return Error{fmt::format("{}: empty file", where)};

  Assimp::Importer importer;
  importer.SetIOHandler(new MeshDirectoryIO(file));  // the importer owns and deletes it
  // Only the formats palpate documents (docs/scene-format.md) and fuzzes (fuzz/): assimp's other
  // readers (3DS, COLLADA, FBX, glTF, ...) are neither tested nor fuzzed here, so they are refused.
  const std::string ext = io::lower_extension(file);
  if (ext != ".obj" && ext != ".stl" && ext != ".ply" && ext != ".off")
    return Error{fmt::format("{}: unknown surface mesh format '{}', expected .obj, .stl, .ply or .off", where, ext)};
  if (ext == ".ply")
    if (Status s = check_ply_header(file); !s) return s.error();
  if (ext == ".off")
    if (Status s = check_off_indices(file); !s) return s.error();
  // Only positions and faces matter: dropping normals, UVs and colours lets
  // JoinIdenticalVertices merge every corner by position.
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
                              aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                  aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                  aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS |
                                  aiComponent_MATERIALS);
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // Read without post-processing first: assimp's own steps assert (and abort the process) on
  // faces a damaged file can produce, such as a face with no indices from a truncated PLY.
  const aiScene* raw = importer.ReadFile(where, 0);
  if (!raw) return Error{fmt::format("{}: assimp could not read the file: {}", where, importer.GetErrorString())};
  if (raw->mNumMeshes == 0 || !raw->mMeshes) return Error{fmt::format("{}: no triangle mesh in the file", where)};
  for (unsigned i = 0; i < raw->mNumMeshes; ++i) {
    const aiMesh* mesh = raw->mMeshes[i];
    if (!mesh || (mesh->mNumFaces > 0 && (!mesh->mFaces || !mesh->mVertices)))
      return Error{fmt::format("{}: mesh {} is incomplete", where, i)};
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices == 0 || !face.mIndices)
        return Error{fmt::format("{}: mesh {} face {} has no vertices (is the file truncated?)", where, i, f)};
      for (unsigned k = 0; k < face.mNumIndices; ++k)
        if (face.mIndices[k] >= mesh->mNumVertices)
          return Error{fmt::format("{}: mesh {} face {} has vertex index {} out of range [0, {})", where, i, f,
                                   face.mIndices[k], mesh->mNumVertices)};
    }
  }
  const aiScene* scene = importer.ApplyPostProcessing(
      aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
      aiProcess_PreTransformVertices | aiProcess_SortByPType);
  if (!scene) return Error{fmt::format("{}: assimp could not process the mesh: {}", where, importer.GetErrorString())};
  if (scene->mNumMeshes == 0 || !scene->mMeshes) return Error{fmt::format("{}: no triangle mesh in the file", where)};

  std::unordered_map<std::array<float, 3>, int, PositionHash> index_of;
  std::vector<std::array<float, 3>> positions;
  std::vector<std::array<int, 3>> triangles;
  for (unsigned i = 0; i < scene->mNumMeshes; ++i) {
    const aiMesh* mesh = scene->mMeshes[i];
    if (!mesh || !mesh->mVertices || !mesh->HasFaces()) continue;
    std::vector<int> merged(mesh->mNumVertices);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      std::array<float, 3> p{mesh->mVertices[v].x, mesh->mVertices[v].y, mesh->mVertices[v].z};
      for (float& x : p)
        if (x == 0.0f) x = 0.0f;  // -0 and +0 are one position
      const auto [it, inserted] = index_of.emplace(p, static_cast<int>(positions.size()));
      if (inserted) positions.push_back(p);
      merged[v] = it->second;
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3 || !face.mIndices) continue;  // points and lines are not surface
      std::array<int, 3> t{};
      for (int k = 0; k < 3; ++k) {
        const unsigned idx = face.mIndices[k];
        if (idx >= mesh->mNumVertices)
          return Error{fmt::format("{}: mesh {} face {} has vertex index {} out of range [0, {})", where, i, f, idx,
                                   mesh->mNumVertices)};
        t[k] = merged[idx];
      }
      triangles.push_back(t);
    }
  }

  SurfaceMesh m;
  m.V.resize(static_cast<Eigen::Index>(positions.size()), 3);
  for (size_t v = 0; v < positions.size(); ++v)
    for (int k = 0; k < 3; ++k) m.V(static_cast<Eigen::Index>(v), k) = scale * static_cast<double>(positions[v][k]);
  m.F.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (size_t f = 0; f < triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) m.F(static_cast<Eigen::Index>(f), k) = triangles[f][k];
  if (Status s = validate(m, where, need); !s) return s.error();

  // The contract is counter-clockwise seen from outside: a closed, consistently oriented surface
  // whose triangles face inward (negative enclosed volume) is turned inside out.
  const topology::EdgeCounts edges = topology::count_edges(topology::sorted_half_edges(m.F));
  if (edges.boundary == 0 && edges.non_manifold == 0 && topology::enclosed_volume(m) < 0)
    for (Eigen::Index f = 0; f < m.F.rows(); ++f) std::swap(m.F(f, 1), m.F(f, 2));
  compute_normals(m);
  return m;
}

}  // namespace palpate
