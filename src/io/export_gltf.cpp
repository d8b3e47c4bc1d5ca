// export_gltf.cpp — GltfScene (palpate/export.h): an animated glTF 2.0 scene written with
// tinygltf (Debian's libtinygltf-dev). tinygltf's header stays in this file.
//
// How it animates, chosen for what browser viewers play (three.js, the Khronos sample viewer,
// Blender's importer): each surface is one mesh whose base is its first frame and whose morph
// target k is frame k's points less the base; one "weights" channel (LINEAR) steps the weights
// one-hot from target to target at the frames' times, so a viewer shows frame k exactly at its
// time and blends neighbouring frames between. Tools are nodes with translation and rotation
// channels at the same times.
#include <palpate/export.h>

#include "core/blade_shape.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

namespace palpate {

namespace {

struct Surface {
  std::string name;
  std::vector<std::uint32_t> triangles;
  std::array<float, 4> rgba{};
  std::vector<std::vector<float>> frames;  // (n x 3) each
};

struct Tool {
  std::string name, shape;
  double radius = 0, length = 0;
  Vec3 axis = Vec3(0, -1, 0), size = Vec3::Zero();
  std::array<float, 4> rgba{};
  std::vector<Vec3> positions;
  std::vector<Quat> orientations;
};

// Appends `bytes` to buffer 0 (4-byte aligned) as a buffer view; returns its index.
int add_view(tinygltf::Model& m, const void* data, size_t bytes, int target) {
  auto& buf = m.buffers[0].data;
  while (buf.size() % 4) buf.push_back(0);
  tinygltf::BufferView v;
  v.buffer = 0;
  v.byteOffset = buf.size();
  v.byteLength = bytes;
  if (target) v.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  buf.insert(buf.end(), p, p + bytes);
  m.bufferViews.push_back(v);
  return int(m.bufferViews.size() - 1);
}

int add_accessor(tinygltf::Model& m, const void* data, size_t count, int component, int type, size_t bytes,
                 int target, std::vector<double> min = {}, std::vector<double> max = {}) {
  tinygltf::Accessor a;
  a.bufferView = add_view(m, data, bytes, target);
  a.componentType = component;
  a.type = type;
  a.count = count;
  a.minValues = std::move(min);
  a.maxValues = std::move(max);
  m.accessors.push_back(a);
  return int(m.accessors.size() - 1);
}

// (n x 3) floats: an accessor with its bounds (glTF requires them on POSITION).
int add_vec3(tinygltf::Model& m, const std::vector<float>& p) {
  std::vector<double> lo(3, std::numeric_limits<double>::infinity()), hi(3, -std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < p.size(); ++i) lo[i % 3] = std::min(lo[i % 3], double(p[i])), hi[i % 3] = std::max(hi[i % 3], double(p[i]));
  if (p.empty()) lo = hi = {0, 0, 0};
  return add_accessor(m, p.data(), p.size() / 3, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                      p.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER, lo, hi);
}

int add_material(tinygltf::Model& m, const std::string& name, const std::array<float, 4>& c) {
  tinygltf::Material mat;
  mat.name = name;
  mat.pbrMetallicRoughness.baseColorFactor = {c[0], c[1], c[2], c[3]};
  mat.pbrMetallicRoughness.metallicFactor = 0.0;
  mat.pbrMetallicRoughness.roughnessFactor = 0.6;
  mat.doubleSided = true;  // open patches are seen from both sides
  if (c[3] < 1.0f) mat.alphaMode = "BLEND";
  m.materials.push_back(mat);
  return int(m.materials.size() - 1);
}

// A tool's shape in its own frame (tip at the origin), as points and triangles.
void tool_shape(const Tool& t, std::vector<float>& p, std::vector<std::uint32_t>& tri) {
  const int seg = 16;
  if (t.shape == "blade") {
    // The scalpel the frames draw: the flat blade on its edge (tip at the origin, heel `length` back
    // along −axis) and its handle behind the heel.
    BladeMesh m;
    const Vec3 axis = t.axis.norm() > 0 && t.axis.allFinite() ? t.axis : Vec3(0, -1, 0);
    const BladeShape s = blade_shape(Vec3::Zero(), axis, std::max(t.length, 1e-4), std::max(t.radius, 1e-5));
    append_blade(m, s);
    append_blade_handle(m, s);
    p = std::move(m.positions);
    tri = std::move(m.triangles);
  } else if (t.shape == "needle") {
    // A cylinder from the tip back along −axis for `length`.
    const Vec3 a = t.axis.normalized();
    const Vec3 u = (std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(a).normalized();
    const Vec3 w = a.cross(u);
    const double r = std::max(t.radius, 1e-4), len = std::max(t.length, 10 * r);
    for (int end = 0; end < 2; ++end)
      for (int k = 0; k < seg; ++k) {
        const double th = 2 * M_PI * k / seg;
        const Vec3 q = -a * (end ? len : 0.0) + r * (std::cos(th) * u + std::sin(th) * w);
        p.insert(p.end(), {float(q.x()), float(q.y()), float(q.z())});
      }
    for (std::uint32_t k = 0; k < std::uint32_t(seg); ++k) {
      const std::uint32_t k1 = (k + 1) % std::uint32_t(seg);
      tri.insert(tri.end(), {k, k1, seg + k, k1, seg + k1, seg + k});
    }
  } else if (t.shape == "box") {
    // Half extents `size`, its face at the origin, standing `length` back along −axis.
    const Vec3 c = -t.axis.normalized() * (0.5 * t.length);
    for (int i = 0; i < 8; ++i)
      p.insert(p.end(), {float(c.x() + (i & 1 ? 1 : -1) * t.size.x()), float(c.y() + (i & 2 ? 1 : -1) * t.size.y()),
                         float(c.z() + (i & 4 ? 1 : -1) * t.size.z())});
    const std::uint32_t f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                    {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    for (const auto& tr : f) tri.insert(tri.end(), {tr[0], tr[1], tr[2]});
  } else {  // sphere: a UV sphere
    const int rings = 8;
    const double r = std::max(t.radius, 1e-4);
    for (int i = 0; i <= rings; ++i)
      for (int k = 0; k < seg; ++k) {
        const double ph = M_PI * i / rings, th = 2 * M_PI * k / seg;
        p.insert(p.end(), {float(r * std::sin(ph) * std::cos(th)), float(r * std::cos(ph)),
                           float(r * std::sin(ph) * std::sin(th))});
      }
    for (std::uint32_t i = 0; i < std::uint32_t(rings); ++i)
      for (std::uint32_t k = 0; k < std::uint32_t(seg); ++k) {
        const std::uint32_t k1 = (k + 1) % std::uint32_t(seg), a = i * seg + k, b = i * seg + k1;
        const std::uint32_t c = (i + 1) * seg + k, d = (i + 1) * seg + k1;
        tri.insert(tri.end(), {a, c, b, b, c, d});
      }
  }
}

}  // namespace

struct GltfScene::Impl {
  std::vector<Surface> surfaces;
  std::vector<Tool> tools;
  std::vector<float> times;
};

GltfScene::GltfScene() : impl_(std::make_unique<Impl>()) {}
GltfScene::~GltfScene() = default;

int GltfScene::add_surface(const std::string& name, std::span<const std::uint32_t> triangles, std::array<float, 4> rgba) {
  impl_->surfaces.push_back({name, {triangles.begin(), triangles.end()}, rgba, {}});
  return int(impl_->surfaces.size() - 1);
}

int GltfScene::add_tool(const std::string& name, const std::string& shape, double radius, double length, const Vec3& axis,
                        const Vec3& size, std::array<float, 4> rgba) {
  Tool t;
  t.name = name, t.shape = shape, t.radius = radius, t.length = length, t.axis = axis, t.size = size, t.rgba = rgba;
  impl_->tools.push_back(std::move(t));
  return int(impl_->tools.size() - 1);
}

void GltfScene::add_frame(double time, std::span<const std::vector<float>> points, std::span<const Vec3> positions,
                          std::span<const Quat> orientations) {
  impl_->times.push_back(float(time));
  for (size_t i = 0; i < impl_->surfaces.size(); ++i) impl_->surfaces[i].frames.push_back(i < points.size() ? points[i] : std::vector<float>{});
  for (size_t i = 0; i < impl_->tools.size(); ++i) {
    impl_->tools[i].positions.push_back(i < positions.size() ? positions[i] : Vec3::Zero());
    impl_->tools[i].orientations.push_back(i < orientations.size() ? orientations[i] : Quat::Identity());
  }
}

size_t GltfScene::frame_count() const { return impl_->times.size(); }

Status GltfScene::write_glb(const std::filesystem::path& file) const {
  const std::string where = file.string();
  const Impl& s = *impl_;
  const size_t nf = s.times.size();
  if (nf == 0) return Error{where + ": no frames to write"};
  tinygltf::Model m;
  m.asset.version = "2.0";
  m.asset.generator = std::string("palpate ") + version();
  m.buffers.resize(1);
  tinygltf::Scene scene;
  scene.name = "palpate run";
  tinygltf::Animation anim;
  anim.name = "run";
  const int time_acc = add_accessor(m, s.times.data(), nf, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR,
                                    nf * sizeof(float), 0, {double(s.times.front())}, {double(s.times.back())});
  for (const Surface& surf : s.surfaces) {
    const std::vector<float>& base = surf.frames.front();
    const size_t n = base.size() / 3;
    for (size_t k = 0; k < nf; ++k)
      if (surf.frames[k].size() != base.size())
        return Error{where + ": surface '" + surf.name + "' has " + std::to_string(surf.frames[k].size() / 3) +
                     " points in frame " + std::to_string(k) + ", " + std::to_string(n) + " in the first"};
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.attributes["POSITION"] = add_vec3(m, base);
    prim.indices = add_accessor(m, surf.triangles.data(), surf.triangles.size(), TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                TINYGLTF_TYPE_SCALAR, surf.triangles.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    prim.material = add_material(m, surf.name, surf.rgba);
    std::vector<float> delta(base.size());
    for (size_t k = 0; k < nf; ++k) {
      for (size_t i = 0; i < base.size(); ++i) delta[i] = surf.frames[k][i] - base[i];
      prim.targets.push_back({{"POSITION", add_vec3(m, delta)}});
    }
    tinygltf::Mesh mesh;
    mesh.name = surf.name;
    mesh.primitives.push_back(prim);
    mesh.weights.assign(nf, 0.0);
    mesh.weights[0] = 1.0;
    m.meshes.push_back(mesh);
    tinygltf::Node node;
    node.name = surf.name;
    node.mesh = int(m.meshes.size() - 1);
    m.nodes.push_back(node);
    scene.nodes.push_back(int(m.nodes.size() - 1));
    if (nf > 1) {
      std::vector<float> w(nf * nf, 0.0f);  // one-hot: at time k, target k
      for (size_t k = 0; k < nf; ++k) w[k * nf + k] = 1.0f;
      tinygltf::AnimationSampler smp;
      smp.input = time_acc;
      smp.output = add_accessor(m, w.data(), w.size(), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR,
                                w.size() * sizeof(float), 0);
      smp.interpolation = "LINEAR";
      anim.samplers.push_back(smp);
      tinygltf::AnimationChannel ch;
      ch.sampler = int(anim.samplers.size() - 1);
      ch.target_node = node.mesh >= 0 ? int(m.nodes.size() - 1) : -1;
      ch.target_path = "weights";
      anim.channels.push_back(ch);
    }
  }
  for (const Tool& t : s.tools) {
    std::vector<float> p;
    std::vector<std::uint32_t> tri;
    tool_shape(t, p, tri);
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.attributes["POSITION"] = add_vec3(m, p);
    prim.indices = add_accessor(m, tri.data(), tri.size(), TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                                tri.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    prim.material = add_material(m, t.name, t.rgba);
    tinygltf::Mesh mesh;
    mesh.name = t.name;
    mesh.primitives.push_back(prim);
    m.meshes.push_back(mesh);
    tinygltf::Node node;
    node.name = t.name;
    node.mesh = int(m.meshes.size() - 1);
    const Vec3& p0 = t.positions.front();
    const Quat& q0 = t.orientations.front();
    node.translation = {p0.x(), p0.y(), p0.z()};
    node.rotation = {q0.x(), q0.y(), q0.z(), q0.w()};  // glTF: x, y, z, w
    m.nodes.push_back(node);
    const int ni = int(m.nodes.size() - 1);
    scene.nodes.push_back(ni);
    std::vector<float> tr, rot;
    for (size_t k = 0; k < nf; ++k) {
      tr.insert(tr.end(), {float(t.positions[k].x()), float(t.positions[k].y()), float(t.positions[k].z())});
      const Quat q = t.orientations[k].normalized();
      rot.insert(rot.end(), {float(q.x()), float(q.y()), float(q.z()), float(q.w())});
    }
    const int tr_acc = add_accessor(m, tr.data(), nf, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                    tr.size() * sizeof(float), 0);
    const int rot_acc = add_accessor(m, rot.data(), nf, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4,
                                     rot.size() * sizeof(float), 0);
    for (const auto& [acc, path] : {std::pair{tr_acc, "translation"}, std::pair{rot_acc, "rotation"}}) {
      tinygltf::AnimationSampler smp;
      smp.input = time_acc;
      smp.output = acc;
      smp.interpolation = "LINEAR";
      anim.samplers.push_back(smp);
      tinygltf::AnimationChannel ch;
      ch.sampler = int(anim.samplers.size() - 1);
      ch.target_node = ni;
      ch.target_path = path;
      anim.channels.push_back(ch);
    }
  }
  if (!anim.channels.empty()) m.animations.push_back(anim);
  m.scenes.push_back(scene);
  m.defaultScene = 0;
  std::ostringstream os;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&m, os, false, true)) return Error{where + ": tinygltf could not write the scene"};
  return write_file_atomic(file, os.str());
}

}  // namespace palpate
