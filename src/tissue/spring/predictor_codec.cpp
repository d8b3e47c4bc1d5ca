// predictor_codec.cpp — the mass-spring predictor as bytes, and the load-or-compute policy
// (palpate/spring.h). The file around the bytes is io's (palpate/checked_file.h); this model
// never opens it: the builder's TissueServices read and write it.
//
// Payload (little-endian) = u64 mesh hash, u64 n, u64 s, u32 solver, u32 anchors, f64 dt,
// f64 point_damping, f64 mass[n], i32 springs[2s], f64 stiffness[s], f64 damping[s],
// i32 anchors[a], then desbrun: f64 inverse[n·n]; sparse: u64 nnz, i32 perm[n], i32 col_start[n+1],
// i32 row[nnz], f64 value[nnz], f64 inv_diag[n].
#include <palpate/spring.h>

#include "tissue/spring/solve.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

namespace palpate {

namespace {

struct Writer {
  std::string buf;
  template <class T>
  void put(const T& v) {
    buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <class T>
  void put_array(const T* p, size_t count) {
    buf.append(reinterpret_cast<const char*>(p), count * sizeof(T));
  }
};

struct Reader {
  const unsigned char* p;
  size_t left;
  template <class T>
  bool get(T& v) {
    if (left < sizeof(T)) return false;
    std::memcpy(&v, p, sizeof(T));
    p += sizeof(T);
    left -= sizeof(T);
    return true;
  }
  template <class T>
  bool get_array(std::vector<T>& out, size_t count) {
    if (count > left / sizeof(T)) return false;
    out.resize(count);
    if (count == 0) return true;  // memcpy from or to a null pointer is undefined even for 0 bytes (UBSan)
    std::memcpy(out.data(), p, count * sizeof(T));
    p += count * sizeof(T);
    left -= count * sizeof(T);
    return true;
  }
};

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

const char* solver_name(std::uint32_t k) {
  switch (k) {
    case 0: return "desbrun";
    case 1: return "sparse";
    case 2: return "exact";
    default: return "unknown";
  }
}

std::uint32_t solver_code(SpringSolver s) {
  return s == SpringSolver::desbrun ? 0u : s == SpringSolver::sparse ? 1u : 2u;
}

// Everything a predictor depends on, in the payload's order: the part decode_predictor compares.
void put_parameters(Writer& w, const SpringNetwork& net, SpringSolver kind, const SpringModelOptions& options) {
  w.put(mesh_hash(net));
  w.put(static_cast<std::uint64_t>(net.size()));
  w.put(static_cast<std::uint64_t>(net.springs.size()));
  w.put(solver_code(kind));
  w.put(static_cast<std::uint32_t>(net.anchors.size()));
  w.put(options.dt);
  w.put(options.point_damping);
  w.put_array(net.mass.data(), net.mass.size());
  w.put_array(net.springs.data()->data(), 2 * net.springs.size());
  // Each spring's weight in A: its stiffness, plus the volume term's share when there is one.
  const std::vector<double> weight = predictor_stiffness(net);
  w.put_array(weight.data(), weight.size());
  w.put_array(net.damping.data(), net.damping.size());
  w.put_array(net.anchors.data(), net.anchors.size());
}

}  // namespace

std::uint64_t mesh_hash(const SpringNetwork& net) {
  Writer w;
  w.put(static_cast<std::uint64_t>(net.rest.rows()));
  for (Eigen::Index i = 0; i < net.rest.rows(); ++i)
    for (int c = 0; c < 3; ++c) w.put(net.rest(i, c));
  return fnv1a64(w.buf.data(), w.buf.size());
}

std::uint64_t predictor_key(const SpringNetwork& network, const SpringModelOptions& options) {
  Writer w;
  put_parameters(w, network, options.solver, options);
  // And the code that computed it: another palpate's predictor (an ordering or factorisation
  // changed since) is never picked up from a shared cache.
  const std::string code = std::string("palpate ") + version();
  w.put_array(code.data(), code.size());
  return fnv1a64(w.buf.data(), w.buf.size());
}

Result<std::string> encode_predictor(const SpringModel& model, const std::string& where) {
  const SpringNetwork& net = model.network;
  const SpringPredictor& p = model.predictor;
  if (p.kind == SpringSolver::exact || p.empty())
    return Error{where + ": the exact solver has no predictor to save (use desbrun or sparse)"};
  Writer w;
  w.buf.reserve(64 + net.size() * 8 + net.springs.size() * 24 + p.inverse.size() * 8 +
                p.value.size() * 12 + net.size() * 16);
  put_parameters(w, net, p.kind, model.options);
  if (p.kind == SpringSolver::desbrun) {
    w.put_array(p.inverse.data(), p.inverse.size());
  } else {
    w.put(static_cast<std::uint64_t>(p.value.size()));
    w.put_array(p.perm.data(), p.perm.size());
    w.put_array(p.col_start.data(), p.col_start.size());
    w.put_array(p.row.data(), p.row.size());
    w.put_array(p.value.data(), p.value.size());
    w.put_array(p.inv_diag.data(), p.inv_diag.size());
  }
  return std::move(w.buf);
}

Result<SpringPredictor> decode_predictor(std::string_view payload, const SpringNetwork& net,
                                         const SpringModelOptions& options, const std::string& where) {
  Reader r{reinterpret_cast<const unsigned char*>(payload.data()), payload.size()};
  std::uint64_t hash, n, s;
  std::uint32_t solver, anchors;
  double dt, gamma;
  if (!r.get(hash) || !r.get(n) || !r.get(s) || !r.get(solver) || !r.get(anchors) || !r.get(dt) || !r.get(gamma))
    return Error{where + "corrupted: payload too short for its parameters"};
  if (hash != mesh_hash(net) || n != net.size())
    return Error{where + "made for another mesh (" + std::to_string(n) + " vertices, mesh hash " + std::to_string(hash) +
                 "; this mesh has " + std::to_string(net.size()) + " vertices, hash " + std::to_string(mesh_hash(net)) + ")"};
  const std::string other = where + "made for other parameters: ";
  if (solver != solver_code(options.solver))
    return Error{other + "solver " + solver_name(solver) + " in the file, " + solver_name(solver_code(options.solver)) + " here"};
  if (dt != options.dt) return Error{other + "dt " + num(dt) + " s in the file, " + num(options.dt) + " s here"};
  if (gamma != options.point_damping)
    return Error{other + "point_damping " + num(gamma) + " N·s/m in the file, " + num(options.point_damping) + " here"};
  if (s != net.springs.size())
    return Error{other + "topology: " + std::to_string(s) + " springs in the file, " + std::to_string(net.springs.size()) + " here"};
  std::vector<double> mass, stiffness, damping;
  std::vector<int> pairs, anchor_list;
  if (!r.get_array(mass, n) || !r.get_array(pairs, 2 * s) || !r.get_array(stiffness, s) || !r.get_array(damping, s) ||
      !r.get_array(anchor_list, anchors))
    return Error{where + "corrupted: payload too short for its parameters"};
  for (size_t i = 0; i < n; ++i)
    if (mass[i] != net.mass[i])
      return Error{other + "mass of vertex " + std::to_string(i) + " is " + num(mass[i]) + " kg in the file, " + num(net.mass[i]) + " kg here"};
  for (size_t e = 0; e < s; ++e)
    if (pairs[2 * e] != net.springs[e][0] || pairs[2 * e + 1] != net.springs[e][1])
      return Error{other + "topology: spring " + std::to_string(e) + " joins " + std::to_string(pairs[2 * e]) + "-" +
                   std::to_string(pairs[2 * e + 1]) + " in the file, " + std::to_string(net.springs[e][0]) + "-" +
                   std::to_string(net.springs[e][1]) + " here"};
  const std::vector<double> weight = predictor_stiffness(net);  // stiffness, plus the volume term's share
  for (size_t e = 0; e < s; ++e)
    if (stiffness[e] != weight[e])
      return Error{other + "stiffness of spring " + std::to_string(e) + " is " + num(stiffness[e]) + " N/m in the file, " + num(weight[e]) + " N/m here" + (net.tets.empty() ? "" : " (with the volume term's share)")};
  for (size_t e = 0; e < s; ++e)
    if (damping[e] != net.damping[e])
      return Error{other + "damping of spring " + std::to_string(e) + " is " + num(damping[e]) + " N·s/m in the file, " + num(net.damping[e]) + " here"};
  if (anchor_list != net.anchors)
    return Error{other + "anchors: " + std::to_string(anchor_list.size()) + " anchored vertices in the file, " +
                 std::to_string(net.anchors.size()) + " here" + (anchor_list.size() == net.anchors.size() ? " (different vertices)" : "")};
  SpringPredictor p;
  p.kind = options.solver;
  p.n = static_cast<int>(n);
  // The numbers themselves, not only the checksum (which anyone editing the file can recompute):
  // A = M + hγ + h·D + h²·K is symmetric positive definite, so A⁻¹ is symmetric with a positive
  // diagonal, and so is D of A's LDLᵀ; a NaN here reset the tissue on every tick.
  if (p.kind == SpringSolver::desbrun) {
    if (!r.get_array(p.inverse, n * n)) return Error{where + "corrupted: the dense inverse is short"};
    double scale = 0;
    for (size_t i = 0; i < n; ++i) {
      const double d = p.inverse[i * n + i];
      if (!std::isfinite(d) || !(d > 0))
        return Error{where + "corrupted: the dense inverse's diagonal entry " + std::to_string(i) + " is " + num(d) +
                     "; expected a positive number"};
      scale = std::max(scale, d);
    }
    for (size_t i = 0; i < n; ++i)
      for (size_t j = 0; j < i; ++j) {
        const double a = p.inverse[i * n + j], b = p.inverse[j * n + i];
        if (!std::isfinite(a) || !std::isfinite(b))
          return Error{where + "corrupted: the dense inverse's entry (" + std::to_string(i) + ", " + std::to_string(j) +
                       ") is not finite"};
        if (std::abs(a - b) > 1e-9 * scale)
          return Error{where + "corrupted: the dense inverse is not symmetric at (" + std::to_string(i) + ", " +
                       std::to_string(j) + "): " + num(a) + " and " + num(b)};
      }
  } else {
    std::uint64_t nnz;
    if (!r.get(nnz) || !r.get_array(p.perm, n) || !r.get_array(p.col_start, n + 1) || !r.get_array(p.row, nnz) ||
        !r.get_array(p.value, nnz) || !r.get_array(p.inv_diag, n))
      return Error{where + "corrupted: the sparse factor is short"};
    // Indices are used unchecked by the solve: check them once here.
    if (p.col_start[0] != 0 || static_cast<std::uint64_t>(p.col_start[n]) != nnz)
      return Error{where + "corrupted: the sparse factor's column starts are inconsistent"};
    for (size_t c = 0; c < n; ++c)
      if (p.col_start[c] > p.col_start[c + 1]) return Error{where + "corrupted: the sparse factor's column starts decrease"};
    for (size_t c = 0; c < n; ++c)
      for (int q = p.col_start[c]; q < p.col_start[c + 1]; ++q)
        if (p.row[static_cast<size_t>(q)] <= static_cast<int>(c) || static_cast<std::uint64_t>(p.row[static_cast<size_t>(q)]) >= n)
          return Error{where + "corrupted: the sparse factor has an entry outside its lower triangle"};
    for (size_t q = 0; q < p.value.size(); ++q)
      if (!std::isfinite(p.value[q]))
        return Error{where + "corrupted: the sparse factor's entry " + std::to_string(q) + " is not finite"};
    for (size_t i = 0; i < n; ++i)
      if (!std::isfinite(p.inv_diag[i]) || !(p.inv_diag[i] > 0))
        return Error{where + "corrupted: the sparse factor's 1/D entry " + std::to_string(i) + " is " +
                     num(p.inv_diag[i]) + "; expected a positive number"};
    std::vector<char> seen(n, 0);
    for (int v : p.perm) {
      if (v < 0 || static_cast<std::uint64_t>(v) >= n || seen[static_cast<size_t>(v)])
        return Error{where + "corrupted: the ordering is not a permutation"};
      seen[static_cast<size_t>(v)] = 1;
    }
  }
  if (r.left != 0) return Error{where + "corrupted: " + std::to_string(r.left) + " unexpected bytes at the end of the payload"};
  // Last, what the checks above cannot see: that the numbers are this network's predictor at all (a
  // factor of another matrix passes every check of form and blows the organ up at rest). The
  // network's own is at round-off (1e-16 to 1e-12 on the shipped organs); 1e-8 leaves room for an
  // ill-conditioned network's dense inverse and is far below what moves a step.
  constexpr double kMaxResidual = 1e-8;
  if (const double res = spring::predictor_residual(net, options, p); !(res <= kMaxResidual))
    return Error{where + "corrupted: the " + (p.kind == SpringSolver::desbrun ? "dense inverse" : "sparse factor") +
                 " is not this network's (solving A x = b with it leaves a relative residual of " + num(res) +
                 ", expected at most " + num(kMaxResidual) + ")"};
  return p;
}

Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       const std::filesystem::path& file, PredictorPolicy policy,
                                       const TissueServices& services, std::string* note, const Progress& progress) {
  if (options.solver == SpringSolver::exact || file.empty()) {
    if (policy == PredictorPolicy::require_file && options.solver != SpringSolver::exact)
      return Error{"a predictor file is required (predictor_policy: require_file) but none is named"};
    if (note) *note = "computed";
    return build_spring_model(std::move(network), options, progress);
  }
  if (!services.read_predictor) return Error{file.string() + ": no predictor reader was handed to the model's builder"};
  // A directory, FIFO or device under the predictor's name is refused by the reader, not computed
  // around and then renamed over (a FIFO would be replaced by the saved file).
  Result<StoredPredictor> stored = services.read_predictor(file);
  if (!stored) return stored.error();
  std::string why = stored->why;
  if (stored->present) {
    Result<SpringPredictor> loaded = decode_predictor(stored->payload, network, options, file.string() + ": ");
    if (loaded) {
      if (note) *note = "loaded " + file.string();
      return build_spring_model(std::move(network), options, std::move(*loaded));
    }
    why = loaded.error().message;
  }
  if (policy == PredictorPolicy::require_file) return Error{why + " (predictor_policy: require_file)"};
  auto model = build_spring_model(std::move(network), options, progress);
  if (!model) return model.error();
  Result<std::string> payload = encode_predictor(*model, file.string());
  Status st = !payload ? Status(payload.error())
              : services.write_predictor ? services.write_predictor(file, *payload)
                                         : Status(Error{file.string() + ": no predictor writer was handed to the model's builder"});
  if (!st) {
    if (note) *note = "computed (" + why + "); not saved: " + st.error().message;
  } else if (note) {
    *note = "computed (" + why + "); saved " + file.string();
  }
  return model;
}

}  // namespace palpate
