// palpate/spring.h — the mass-spring-damper organ model: networks from meshes, the precomputed
// implicit predictor (Desbrun, Schröder & Barr 1999), its file, and the 1 kHz step.
#pragma once

#include <palpate/core.h>
#include <palpate/mesh.h>
#include <palpate/spring_def.h>
#include <palpate/tissue.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <new>
#include <span>
#include <utility>
#include <string>
#include <string_view>
#include <vector>

namespace palpate {

// Which vertex pairs get a spring (DESIGN.md §2).
enum class SpringTopology {
  all_pairs,  // every vertex to every other: the seed paper's organs (small meshes only)
  edges,      // the mesh's edges (a surface's triangle edges, or a tet mesh's edges)
  tet_edges,  // a tetrahedral mesh's edges (a closed surface is filled with tetrahedra first)
};

// How the implicit backward-Euler step is solved.
enum class SpringSolver {
  desbrun,  // precomputed dense inverse of M + hD + h²K_const, plus the angular-momentum correction
  sparse,   // precomputed sparse LDLᵀ of the same matrix (nested dissection or AMD, whichever
            // fills less), solved per tick with supernodes
  exact,    // Newton on the full non-linear backward Euler, re-assembled each step (reference)
};

// How the tool touches the organ.
// How a step advances the state (docs/models/mass-spring.md, "Integrators"). Both solve one system
// with the predictor's constant matrix A = M + h(γI + C_L) + h²K_L per step, h = SpringModelOptions::dt.
enum class SpringIntegrator {
  backward_euler,  // DS99: one backward-Euler step of h; first order
  bdf2,            // the second-order backward differentiation formula at step H = 1.5 h: a backward-Euler
                   // step of h = 2H/3 from the extrapolated state (4 x_n − x_{n−1})/3, (4 v_n − v_{n−1})/3.
                   // L-stable like backward Euler (stiff modes are damped, not rung), but a mode of time
                   // constant τ decays at e^(−H/τ) to second order instead of 1/(1 + H/τ)
};

enum class SpringContact {
  surface,   // the tool's sphere against the surface triangles, a penalty k_c·depth made implicit by a
             // per-tick correction and carried from tick to tick (docs/models/mass-spring.md, "Contact")
  vertices,  // the first model: an explicit penalty on each vertex inside the sphere, k_c clamped to
             // (m_i + hγ)/h² for stability (a probe smaller than the spacing slips between vertices)
};

// What building a model does when its predictor file is missing or does not match.
enum class PredictorPolicy {
  load_or_compute,  // load the file when it matches; otherwise compute (and write it, if named)
  require_file,     // load the file or fail with the reason it was refused
};

// A mass-spring-damper network: the constant part of an organ. n vertices, s springs.
struct SpringNetwork {
  RowMat3d rest;                              // (n x 3) rest positions, m
  std::vector<double> mass;                   // (n) kg
  std::vector<std::array<int, 2>> springs;    // (s) vertex pairs, i < j, no duplicates
  std::vector<double> rest_length;            // (s) m
  std::vector<double> stiffness;              // (s) N/m
  std::vector<double> damping;                // (s) N·s/m, along the spring
  std::vector<std::array<int, 3>> triangles;  // the drawn surface over the vertices (may be empty)
  std::vector<int> anchors;                   // fixed vertices, sorted, unique
  // The volume term (docs/models/mass-spring.md, "Volume"): on each tetrahedron T the energy
  // ½ κ (V_T − V0_T)² / V0_T, a force −κ (V_T − V0_T)/V0_T ∇V_T on its corners. Empty or κ = 0: none.
  std::vector<std::array<int, 4>> tets;       // (T) tetrahedra, positively oriented at rest
  std::vector<double> rest_volume;            // (T) m³
  double volume_modulus = 0;                  // Pa, κ
  size_t size() const { return mass.size(); }
};

// The weight of each spring in the predictor's constant matrix: its stiffness plus the volume
// term's share, the isotropic part of its rest Hessian (β κ / V0) G_ab with G_ab = −∇_a V0 · ∇_b V0
// summed over the tetrahedra holding the edge (β = kVolumePredictorScale). (s) N/m; equal to
// network.stiffness when there is no volume term. Every tetrahedron's edges must be springs.
inline constexpr double kVolumePredictorScale = 1.5;
std::vector<double> predictor_stiffness(const SpringNetwork& network);

// How a network is made from a mesh.
struct SpringNetworkOptions {
  SpringTopology topology = SpringTopology::edges;
  double stiffness = 100.0;      // N/m per spring; used when youngs_modulus == 0
  double youngs_modulus = 0.0;   // Pa; > 0 derives stiffness (docs/models/mass-spring.md)
  double spring_damping = 0.1;   // N·s/m per spring
  double mass = 0.1;             // kg total, shared equally; used when density == 0
  double density = 0.0;          // kg/m³; > 0 lumps each vertex's mass from the volume it carries
  // > 0 (tetrahedral meshes with youngs_modulus, in [0.25, 0.5)): springs carry the shear modulus
  // μ = E / 2(1 + ν) and a per-tetrahedron volume term the rest of the bulk modulus, so the
  // network responds as an isotropic solid of (E, ν) (docs/models/mass-spring.md). 0: springs only.
  double poisson_ratio = 0.0;
  std::vector<int> anchors;      // fixed vertex indices
  // How spring_network_from_file fills a surface with tetrahedra (tet_edges): largest size and
  // graded regions (tetrahedralize). Unused for tet files and other topologies.
  FillOptions fill;
};

// Parse a material's strings (topology, solver, predictor_policy) into options; errors name `where`.
Result<SpringNetworkOptions> network_options(const SpringMaterialDef& m, std::vector<int> anchors,
                                             const std::string& where);
Result<SpringSolver> parse_solver(const std::string& name, const std::string& where);

// A network over a tetrahedral mesh: topology tet_edges/edges (its edges) or all_pairs; the drawn
// triangles are its boundary. `where` names the source in messages.
Result<SpringNetwork> make_spring_network(const TetMesh& mesh, const SpringNetworkOptions& options,
                                          const std::string& where);
// A network over a surface: topology edges or all_pairs (tet_edges needs tetrahedralize first).
Result<SpringNetwork> make_spring_network(const SurfaceMesh& mesh, const SpringNetworkOptions& options,
                                          const std::string& where);
// Checks sizes, indices, positive masses and lengths, finite values; fills nothing.
Status validate(const SpringNetwork& network, const std::string& where);

struct SpringModelOptions {
  double dt = 0.001;                           // s, the step the predictor is built for (h); a step
                                               // advances the state by step_length() (h, or 1.5 h for bdf2)
  SpringIntegrator integrator = SpringIntegrator::backward_euler;
  SpringSolver solver = SpringSolver::desbrun;
  double point_damping = 0.5;                  // N·s/m, the paper's −γẋ on each mass
  bool gravity = true;
  double gravity_acceleration = 9.8;           // m/s², along −y
  bool angular_momentum_correction = true;     // the predictor's post-step correction
  SpringContact contact = SpringContact::surface;
  double contact_stiffness = 500.0;            // N/m: surface, tool force per metre of depth (the device's
                                               // rendered stiffness in series with the tissue's); vertices,
                                               // per vertex inside the probe (clamped for stability)
  double contact_damping = 0.05;               // N·s/m along the contact normal (vertices: per vertex inside)
  double grasp_radius = 0.002;                 // m beyond the tool's radius that grasping reaches
  double grasp_stiffness = 200.0;              // N/m per grasped vertex (clamped for stability)
  double grasp_release_time = 0.05;            // s: a let-go grasp's springs fade to zero over this
                                               // (the jaws opening), not at once; 0: at once
  int newton_iterations = 30;                  // exact solver: most Newton iterations per step
  double newton_tolerance = 1e-10;             // exact solver: stop when |Δv| ≤ tol · (1 + |v|), m/s
  double max_speed = 50.0;                     // m/s; faster means blow-up: the state is reset
  size_t dense_limit = 4000;                   // most vertices the dense predictor accepts
  // The per-tick predictor (dense A⁻¹ or the supernodal factor) kept in float, read into double
  // sums (on AVX-512 machines the factor's wide blocks are multiplied and summed in float, sixteen
  // lanes at a time): half the memory traffic of the solve and, there, half its multiply-adds. Δv then carries a relative error of about 1e-6
  // (test SpringSolve.SinglePrecisionErrorIsBounded), so momentum is conserved to that level and
  // not to round-off. Predictor files still hold doubles; this is not part of their parameters.
  // On an all-pairs network with one stiffness and damping it also computes the O(n²) spring
  // forces in float (tool force within 1e-4 of its peak: test
  // SpringSolve.SinglePrecisionAllPairsForcesStayWithinTheirBound).
  bool single_precision = false;
  // Backward Euler's own damping (docs/models/mass-spring.md, "Damping"): after the predictor's
  // step, this many preconditioned conjugate-gradient iterations on the exact linearised backward
  // Euler system (the full spring Jacobian, as the exact solver's, and the volume term's), with the
  // predictor as the preconditioner. Each costs one more solve and one pass over springs and
  // tetrahedra. 0: the predictor alone (its transverse stiffness damps transverse motion more).
  int exact_iterations = 0;
  // Backward Euler's damping without a second solve (docs/models/mass-spring.md, "Damping"): the
  // right-hand side's −h K v term with each spring's exact stiffness k[uuᵀ + max(0, 1 − L/l)(I − uuᵀ)]
  // (the direction the constant matrix drops) instead of the predictor's k I, computed in the same
  // pass as the spring forces. The volume term's share stays the predictor's (its exact part in the
  // right-hand side would not be stable). Stable: per spring the exact stiffness is ≤ k I. Generic
  // (not all-pairs) networks; ignored when exact_iterations > 0 (the two are alternatives).
  bool directional_correction = false;
};

// The time one step() advances (s): dt for backward Euler, 1.5 dt for BDF2.
inline double step_length(const SpringModelOptions& o) noexcept {
  return o.integrator == SpringIntegrator::bdf2 ? 1.5 * o.dt : o.dt;
}

// The precomputed predictor: A = M + h(γI + C_L) + h²K_L over the n vertices, where K_L and C_L are
// the stiffness- and damping-weighted graph Laplacians (the constant, direction-free part of the
// spring Jacobian, DS99 §4.2) and anchored rows/columns are replaced by the identity. One n x n
// matrix serves the three coordinates.
struct SpringPredictor {
  SpringSolver kind = SpringSolver::exact;  // desbrun: dense inverse; sparse: LDLᵀ; exact: empty
  int n = 0;
  std::vector<double> inverse;   // desbrun: (n x n) row-major A⁻¹
  std::vector<int> perm;         // sparse: (n) the fill-reducing ordering, new index of vertex i
  std::vector<int> col_start;    // sparse: (n + 1) start of each column of L in row/value
  std::vector<int> row;          // sparse: (nnz) row of each strictly-lower entry of L (permuted)
  std::vector<double> value;     // sparse: (nnz) L's entries; L has a unit diagonal
  std::vector<double> inv_diag;  // sparse: (n) 1 / D
  bool empty() const { return inverse.empty() && value.empty() && inv_diag.empty(); }
};

namespace spring {
struct SolverLayouts;  // src/tissue/spring/layouts.h
}

// The solvers' own layouts of a model's data — the supernodal form of the sparse factor, the float
// copies of the predictor and rest lengths, the volume pass's lanes — derived when the model is
// built and never stored in files. Opaque here (internal: src/tissue/spring/layouts.h); copied
// with the model (a deep copy). A moved-from one holds nothing and may only be assigned to.
class SpringSolverLayouts {
 public:
  SpringSolverLayouts();
  SpringSolverLayouts(const SpringSolverLayouts& other);
  SpringSolverLayouts(SpringSolverLayouts&& other) noexcept;
  SpringSolverLayouts& operator=(const SpringSolverLayouts& other);
  SpringSolverLayouts& operator=(SpringSolverLayouts&& other) noexcept;
  ~SpringSolverLayouts();
  spring::SolverLayouts* operator->() noexcept { return layouts_.get(); }
  const spring::SolverLayouts* operator->() const noexcept { return layouts_.get(); }
  spring::SolverLayouts& operator*() noexcept { return *layouts_; }
  const spring::SolverLayouts& operator*() const noexcept { return *layouts_; }

 private:
  std::unique_ptr<spring::SolverLayouts> layouts_;
};

// The constant part of a simulated organ, shared read-only by threads.
struct SpringModel {
  SpringNetwork network;
  SpringModelOptions options;
  SpringPredictor predictor;
  SpringSolverLayouts solver;           // the solvers' layouts of the predictor and the network (opaque)
  double uniform_stiffness = 0;         // N/m when every spring has this stiffness (else 0): K_L v in O(n)
  std::vector<double> predictor_stiffness;  // (s) N/m, each spring's weight in A (predictor_stiffness())
  bool volume_term = false;             // the network has tetrahedra with a volume modulus > 0
  std::vector<int> surface_vertices;    // the vertices of network.triangles, each once, ascending
  bool uniform_damping = false;         // every spring has the same damping (the all-pairs kernel reads
                                        // no per-spring stiffness or damping when both are uniform)
  std::vector<std::uint8_t> anchored;   // (n) 1 for a fixed vertex
  std::vector<double> max_contact_stiffness;  // (n) N/m, (m_i + hγ)/h²: the stiffest explicit penalty
                                              // on vertex i that stays stable, since A⁻¹ ≤ (M + hγ)⁻¹
  std::vector<int> adjacency_start;     // (n + 1) CSR of springs per vertex
  std::vector<int> adjacency;           // (2s) spring indices touching each vertex
  double total_mass = 0;                // kg
  bool closed_surface = false;          // every triangle edge shared by two triangles: inside is defined
  std::vector<double> contact_compliance;  // (n) 1 / (m_i + hγ), 0 for an anchored vertex: an upper bound
                                           // of the vertex's row of A⁻¹ (A ≥ M + hγI), 1/kg
  // contact_compliance holds each surface vertex's exact (A⁻¹)_ii instead of the mass bound
  // (use_exact_contact_compliance): the step's c is then the Cauchy–Schwarz bound (Σ_i |g_i| √(A⁻¹)_ii)².
  bool contact_compliance_exact = false;
  bool all_pairs = false;               // springs are every pair (i < j) in order: the O(n²) kernel
};

// Progress of a long build in [0, 1]; called off any real-time path.
using Progress = std::function<void(double fraction)>;

// Build the predictor of `network` for `options` (the expensive, cacheable phase).
Result<SpringPredictor> build_predictor(const SpringNetwork& network, const SpringModelOptions& options,
                                        const Progress& progress = {});
// Assemble a model. When `predictor` is given it is used as is (loaded from a file, already checked);
// otherwise it is built.
Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       const Progress& progress = {});
Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       SpringPredictor predictor);

// A tool's grasp (SpringState::grasp): the vertices tied to it on springs and their offsets from its
// tip when grabbed.
struct SpringGrasp {
  static constexpr int kMaxGrasped = 16;
  std::array<int, kMaxGrasped> grasped{};
  std::array<Vec3, kMaxGrasped> offset{};
  int count = 0;
  bool grasping = false;  // the tool holds (its grasp is on); count > 0 without it: letting go
  double hold = 0;        // 1 held, down to 0 over grasp_release_time once let go (the springs' share
                          // of grasp_stiffness is its smoothstep)
};

// Everything that changes, plus the scratch the step needs (sized at make_state: no allocation later).
struct SpringState {
  RowMat3d x;       // (n x 3) positions, m
  RowMat3d v;       // (n x 3) velocities, m/s
  double time = 0;  // s
  // bdf2: the state one step back (sized by make_state; has_prev false after make_state and reset:
  // the first step then extrapolates from the present state alone).
  RowMat3d x_prev, v_prev;
  bool has_prev = false;
  // Scratch, (n x 3) each.
  RowMat3d force, rhs, dv, work;
  RowMat3d cg_r, cg_z, cg_p, cg_q, cg_d;  // exact_iterations > 0: the conjugate gradients' vectors
  std::vector<float> soa_single;  // all-pairs kernel in single precision: (9n) as soa, in float
  std::vector<double> soa;  // all-pairs kernel: (9N + 8), N = n rounded up to 8, structure-of-arrays
                            // copies from the first 64-byte boundary; other networks'
                            // spring pass: (16n + 7) x and v, f and r, eight doubles per vertex;
                            // sparse solve: (4n + 3·max_height, rounded up to 8) the permuted right-hand side as
                            // (x, y, z, 0) per vertex, and the block being solved (used one after the other;
                            // the fused sparse step puts the solve's after the spring pass's, both at once)
  // Grasping: vertices attached to the tool and their offsets from the tip when grabbed.
  static constexpr int kMaxGrasped = SpringGrasp::kMaxGrasped;
  SpringGrasp grasp;
  // A second tool in the other hand (Tissue::set_second_tool: a grasper), when has_second_tool: it
  // grasps as the first does and presses as a probe (an explicit penalty on the vertices inside it,
  // whatever the contact mode), its own grasp; second_tool_force the force on it after the step.
  ToolState second_tool;
  bool has_second_tool = false;
  SpringGrasp second_grasp;
  Vec3 second_tool_force = Vec3::Zero();  // N
  // What the last step found.
  // Surface contact: the contact force the last step ended with, on each vertex it acts on (the next
  // step starts with it as an external force, then corrects it), and its size F (N).
  // (A fine mesh under a large tool — a graded mesh under an indenter — holds a few hundred.)
  static constexpr int kMaxContactVertices = 256;
  static constexpr int kMaxContactTriangles = 256;
  std::array<int, kMaxContactVertices> contact_vertex{};
  std::vector<std::uint8_t> contact_code;  // per vertex, scratch of the contact's cull (which side of the
                                           // tool's box it lies on); sized by make_state
  std::vector<int> contact_slot;     // per vertex, its index in contact_vertex while a step builds it, else −1
                                     // (scratch sized by make_state; empty: a linear search)
  std::array<Vec3, kMaxContactVertices> contact_load{};  // N, on the organ at contact_vertex
  int contact_vertex_count = 0;
  double contact_force = 0;          // N, F = k_c · depth once settled
  double contact_depth = 0;          // m, the tool's sphere into the surface after the last step
  Vec3 carried_on_tool = Vec3::Zero();  // N, the carried force's reaction on the tool this step
  Vec3 tool_force = Vec3::Zero();    // N, on the tool
  Vec3 anchor_force = Vec3::Zero();  // N, exerted by the anchors on the organ
  int contacts = 0;                  // vertices inside the probe
  int newton_iterations = 0;         // exact solver: iterations of the last step
  std::uint64_t resets = 0;          // blow-ups recovered
};

// A state at rest, with scratch sized for `model`.
SpringState make_state(const SpringModel& model);
// Back to rest (positions = rest, zero velocity, no grasp); keeps the scratch.
void reset(const SpringModel& model, SpringState& state) noexcept;

// One backward-Euler step of length model.options.dt with the tool (nullptr = no tool).
// Returns false when the state blew up (non-finite or faster than max_speed): it was then reset
// and the tool force is zero. noexcept, and for desbrun and sparse allocation-free; the exact
// solver re-assembles and factorises a sparse matrix each Newton iteration (it allocates).
bool step(const SpringModel& model, SpringState& state, const ToolState* tool) noexcept;

// Figures of a state.
double kinetic_energy(const SpringModel& model, const SpringState& state) noexcept;        // J
double elastic_energy(const SpringModel& model, const SpringState& state) noexcept;        // J
Vec3 linear_momentum(const SpringModel& model, const SpringState& state) noexcept;         // kg·m/s
Vec3 angular_momentum(const SpringModel& model, const SpringState& state) noexcept;        // about 0
double max_displacement(const SpringModel& model, const SpringState& state) noexcept;      // m

struct ContactPatch;  // palpate/contact.h

// The compliance of an organ's vertices to loads held over one step (issue 24; docs/haptics.md,
// Multi-rate): a force L_j (N) on vertex j enters the step's right-hand side as h L_j, so the step
// moves vertex i by W_ij L_j more, W = h² A⁻¹ (m/N), the same for x, y and z (A is one n x n matrix
// for the three). Exact for the predictor's own step (not an approximation of a warped stiffness):
// with the sparse factor A = Pᵀ L D Lᵀ P, (A⁻¹)_ij = z_iᵀ z_j where z_i = D^-½ L⁻¹ P e_i is nonzero
// only on the elimination-tree path from vertex i's column to the root, so each vertex costs one
// forward substitution along its path (not a full solve); z_i is cached per vertex (least recently
// used out first) and a block of W is Zᵀ Z over the union of the paths. With the dense predictor
// W_ij is read from A⁻¹. Anchored vertices have W = 0. Not for the haptic thread (it allocates when
// it meets a longer union than before).
class SpringCompliance {
 public:
  // capacity: the most vertices whose z_i are kept.
  explicit SpringCompliance(const SpringModel& model, int capacity = 1024);
  // The model has a predictor (sparse or dense) and this works.
  bool available() const noexcept { return available_; }
  // W (m/N) among `vertices` into w, row-major (count x count).
  void block(std::span<const int> vertices, std::span<double> w);
  // Fill `patch` from the state after a step (docs/haptics.md, Multi-rate): the surface vertices
  // nearest the tool's centre within reach of its sphere plus `margin` (m) (at most
  // ContactPatch::kMaxPoints), the surface triangles over them, W among them, and their free
  // positions: the positions after the step less the contact load's share, x_i − Σ_j W_ij L_j (L_j
  // the contact force on vertex j that the step ended with). False when the model has no surface
  // triangles or predictor, or no surface vertex is within reach.
  bool contact_patch(const SpringState& state, const ToolState& tool, double margin, ContactPatch& patch);
  // The vertices of the last patch, in its point order.
  const std::vector<int>& patch_vertices() const noexcept { return patch_vertices_; }
  // (A⁻¹)_ii (1/kg; W_ii = h² (A⁻¹)_ii) of each of `vertices` into d: forward substitutions eight at
  // a time, not cached (0 for an anchored vertex).
  void diagonal(std::span<const int> vertices, std::span<double> d);
  // The vertices of the surface triangles.
  const std::vector<int>& surface() const noexcept { return surface_; }
  std::uint64_t computed() const noexcept { return computed_; }  // vertices' z_i computed so far
  size_t cached() const noexcept { return cached_; }

 private:
  void compute(std::span<const int> vertices);
  const SpringModel& model_;
  bool available_ = false;
  int n_ = 0;
  std::vector<int> parent_;             // (n) elimination-tree parent of each permuted column, −1 at a root
  struct Slot {
    int vertex = -1;
    std::uint64_t used = 0;
    std::vector<int> index;    // ascending permuted columns of the path
    std::vector<double> z;     // z_i there
  };
  std::vector<Slot> slots_;
  std::vector<int> slot_of_;            // (n) slot of a vertex, −1 when not cached
  std::vector<double> y_;               // (8n) forward substitution of up to eight vertices at once
  std::vector<int> mark_, union_;       // (n) scratch
  std::vector<double> dense_;           // union x count, for the block's product
  std::vector<int> surface_;            // vertices of the surface triangles
  std::vector<int> tri_start_, tri_of_; // CSR: surface triangles of each vertex
  double max_edge_ = 0;                 // m, longest surface edge at rest
  std::vector<std::pair<double, int>> near_;  // scratch: (distance, vertex)
  std::vector<int> local_;              // (n) index of a vertex in the patch being built, −1 if none
  std::vector<int> patch_vertices_;     // the last patch's vertices (W reused when they repeat)
  std::vector<double> patch_w_;
  std::uint64_t clock_ = 0, computed_ = 0;
  size_t cached_ = 0;
};

// The model's own contact (surface_contact in step.cpp) against the exact diagonal of A⁻¹ instead of
// the mass bound 1/(m_i + hγ): each surface vertex's (A⁻¹)_ii into contact_compliance and
// contact_compliance_exact set, so the step's compliance c = (Σ_i |g_i| √(A⁻¹)_ii)² — still an upper
// bound of gᵀA⁻¹g (|(A⁻¹)_ij| ≤ √((A⁻¹)_ii (A⁻¹)_jj)), but close to it where the mass bound is 10⁴
// too loose (a long step on a stiff organ), so the step's contact agrees with the exact compliance
// the multi-rate loop renders (issue 24). One forward substitution per surface vertex, at build time.
// False (the model unchanged) when it has no predictor or no surface.
bool use_exact_contact_compliance(SpringModel& model);

// Predictors as bytes (the file around them is palpate/tissue_files.h's; docs/models/mass-spring.md).
// FNV-1a 64 of the network's rest positions: the "mesh" a predictor was made for.
std::uint64_t mesh_hash(const SpringNetwork& network);
// FNV-1a 64 of everything a predictor depends on (what decode_predictor compares): the name of a
// cached predictor, so one made for this network and these options is found again.
std::uint64_t predictor_key(const SpringNetwork& network, const SpringModelOptions& options);
// The model's predictor with every parameter it depends on, as a predictor file's payload. An
// exact-solver model has none (an error naming `where`).
Result<std::string> encode_predictor(const SpringModel& model, const std::string& where);
// A payload's predictor, when it was made for exactly this network and these options; a short,
// corrupted, other-mesh or other-parameter payload is refused with a message, headed by `where`
// (the file and ": "), saying which.
Result<SpringPredictor> decode_predictor(std::string_view payload, const SpringNetwork& network,
                                         const SpringModelOptions& options, const std::string& where);

// A model from a network with the predictor policy: load `file` (through services.read_predictor)
// when it matches, else compute it (and store it with services.write_predictor when `file` is not
// empty), or fail under require_file. A `file` that exists but is not a regular file is refused.
// `note` (optional) is told what happened ("loaded", or why it was recomputed).
Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       const std::filesystem::path& file, PredictorPolicy policy,
                                       const TissueServices& services, std::string* note = nullptr,
                                       const Progress& progress = {});

// What a scene's mass_spring tissue asks for: its network (from TissueDef::mesh — a tet file, or a
// surface, filled with tetrahedra by tetrahedralize() when the topology is tet_edges — or from
// TissueDef::patch, a flat sheet), the model options (dt = the scene's tick), and the predictor file
// (TissueDef::spring.predictor resolved against the scene's directory, or, when it names none, the
// builder's predictor cache: "<services.predictor_cache>/<name>-<predictor_key as 16 hex>.predictor").
struct SpringTissueSetup {
  SpringNetwork network;
  SpringModelOptions options;
  std::filesystem::path predictor;
  PredictorPolicy policy = PredictorPolicy::load_or_compute;
};
Result<SpringTissueSetup> spring_setup(const SceneDef& scene, int index, const TissueServices& services);

// A mass-spring tissue's model and live state, read-only (Tissue::spring_body()): positions and
// velocities are (n x 3) row-major float64 (SpringState::x, v).
struct SpringBody {
  const SpringModel* model = nullptr;
  const SpringState* state = nullptr;
};

// A scene tissue over a built model (tests, benchmarks, embedding programs): step(tool, dt) runs
// dt / model.options.dt steps; it offers the loop its compliant contact patch
// (ContactComplianceSource, palpate/haptics.h) when dt is one step.
std::unique_ptr<Tissue> make_spring_tissue(std::string name, SpringModel model);

// Cutting (issue 37, docs/models/cutting.md). A blade removes springs and the tetrahedra that hold
// them from a live model. Their forces are gone from the next step (stiffness, damping and predictor
// weight set to zero in the model, the volume term's share of each removed tetrahedron taken off its
// edges); the predictor's constant matrix A loses their weight, a low-rank change, and the step stays
// exact to the cut network by a Woodbury correction computed off the haptic thread and installed
// from the tick it is ready; once the correction holds more than refactor_rank edges a new factor
// (the same ordering and pattern, new values) is built off the thread and swapped in. Until a
// removal's correction is installed the step solves with the matrix that still holds the removed
// weight: the removed springs pull no more, only their implicit damping lingers for those ticks.
struct SpringCutOptions {
  int refactor_rank = 48;     // edges in a correction past which a new factor is built
  int max_rank = 256;         // the most edges one correction holds; beyond, the step waits for the factor
  int max_removals = 65536;   // the most springs and tetrahedra removed in a run
  // Deterministic installs (headless runs and replays): a removal's correction, and a new factor, take
  // effect exactly this many install() calls after the removal that made them due, the haptic thread
  // waiting for the worker if it is late. < 0: as soon as ready (real time).
  int fixed_latency = -1;
};

// What a cutter has done (figures, summary).
struct SpringCutStatus {
  int removed_springs = 0;
  int removed_tets = 0;
  int pending = 0;               // removals whose correction is not installed yet
  int correction_rank = 0;       // edges in the installed correction
  int factors = 0;               // new factors installed
  std::uint64_t installs = 0;    // corrections installed
  int installed = 0;             // removals (springs and tetrahedra, in the order removed) the solve in
                                 // use covers: recorded per tick (cut_installed), replayed by a schedule
  int replay_mismatches = 0;     // install() calls whose schedule asked for what the run had not logged
  double last_correction_ms = 0; // the worker's time for the last correction
  double last_factor_ms = 0;     // and for the last new factor
};

class SpringCutter {
 public:
  // Cuts `model` (not owned; it must outlive the cutter and be stepped only by the thread that calls
  // remove_* and install()). Starts the worker thread. The model must have a predictor (desbrun or
  // sparse, built by build_spring_model) and no correction installed by another cutter.
  static Result<std::unique_ptr<SpringCutter>> create(SpringModel& model, const SpringCutOptions& options = {});
  ~SpringCutter();
  SpringCutter(const SpringCutter&) = delete;
  SpringCutter& operator=(const SpringCutter&) = delete;

  // Stepping thread: remove springs (indices into network.springs) and every tetrahedron holding
  // one; their forces are zero from the next step. Returns how many springs were newly removed
  // (already removed, out-of-range ones and those past max_removals are skipped). noexcept, no
  // allocation, no lock.
  int remove_springs(std::span<const int> springs) noexcept;
  // Stepping thread: remove tetrahedra (their volume term, and their share of their edges' predictor
  // weight); their springs stay. Returns how many were newly removed.
  int remove_tets(std::span<const int> tets) noexcept;
  // Stepping thread, once per tick before the step: installs what the worker has ready (pointer
  // swaps; the replaced data goes back to the worker to be freed). True when the step's solve changed.
  bool install() noexcept;
  // Waits until every removal so far is corrected and installs it (tests, benchmarks, the end of a
  // headless run). Not for the haptic thread.
  void settle();
  SpringCutStatus status() const noexcept;
  // Switch between fixed-latency installs (latency >= 1 ticks) and as-soon-as-ready ones (latency < 0),
  // SpringCutOptions::fixed_latency. Stepping thread, between ticks.
  void set_fixed_latency(int latency) noexcept;
  // Replays (docs/models/cutting.md, "Recording and replay"): from the next install() call on, the
  // i-th call installs what covers installed[i] removals — a recorded run's status().installed, tick
  // by tick — waiting for the worker as fixed_latency does, so the replay's corrections and new
  // factors take effect at the recorded ticks (the worker builds the same coverages, so the same
  // corrections and factors). Followed while installs are deterministic (fixed_latency >= 1); past
  // its end, fixed_latency again. A value past the removals logged when due installs what is logged
  // (never a wait for removals that will not come) and counts status().replay_mismatches. Stepping
  // thread, between ticks; allocates the copy. An error for a value < 0 or below the one before.
  Status set_install_schedule(std::span<const std::int32_t> installed);
  // Per spring / tetrahedron, 1 where removed (read on the stepping thread or while it is paused).
  const std::vector<std::uint8_t>& removed_springs() const noexcept;
  const std::vector<std::uint8_t>& removed_tets() const noexcept;

 private:
  struct Impl;
  explicit SpringCutter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// A network from a mesh file (tetrahedral formats by extension, else a surface; filled with
// tetrahedra for tet_edges), read and filled through `services`.
Result<SpringNetwork> spring_network_from_file(const MeshRef& mesh, const SpringNetworkOptions& options,
                                               const TissueServices& services);

}  // namespace palpate
