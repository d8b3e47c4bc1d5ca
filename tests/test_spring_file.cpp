// test_spring_file.cpp — the predictor file: round trip, and each kind of bad file refused with
// the message that says why; the load-or-compute / require-file policy.
#include <palpate/tissue_files.h>
#include "spring_fixtures.h"

#include "simulation/predictor_file.h"
#include "tissue/spring/solve.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <fstream>
#include <string>

using namespace palpate;
using namespace spring_test;

namespace {

std::filesystem::path temp_file(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("palpate_spring_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir / name;
}

std::string read_all(const std::filesystem::path& f) {
  std::ifstream in(f, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_all(const std::filesystem::path& f, const std::string& s) {
  std::ofstream out(f, std::ios::binary | std::ios::trunc);
  out.write(s.data(), static_cast<std::streamsize>(s.size()));
}

SpringModelOptions opts(SpringSolver solver) {
  SpringModelOptions o;
  o.solver = solver;
  return o;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(SpringPredictorFile, RoundTripGivesTheSamePredictorAndTheSameSteps) {
  for (SpringSolver solver : {SpringSolver::desbrun, SpringSolver::sparse}) {
    const SpringNetwork net = block_network(4, 4, 4, 0.01, 300.0, 0.1, true, 0.05);
    SpringModel built = must_build(net, opts(solver));
    const auto file = temp_file(solver == SpringSolver::desbrun ? "dense.predictor" : "sparse.predictor");
    ASSERT_TRUE(save_predictor(file, built).ok());
    EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp." + std::to_string(::getpid())));
    auto loaded = load_predictor(file, net, opts(solver));
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    EXPECT_EQ(loaded->inverse, built.predictor.inverse);
    EXPECT_EQ(loaded->perm, built.predictor.perm);
    EXPECT_EQ(loaded->col_start, built.predictor.col_start);
    EXPECT_EQ(loaded->row, built.predictor.row);
    EXPECT_EQ(loaded->value, built.predictor.value);
    EXPECT_EQ(loaded->inv_diag, built.predictor.inv_diag);
    auto from_file = build_spring_model(net, opts(solver), std::move(*loaded));
    ASSERT_TRUE(from_file.ok());
    SpringState a = make_state(built), b = make_state(*from_file);
    for (int i = 0; i < 50; ++i) {
      ASSERT_TRUE(step(built, a, nullptr));
      ASSERT_TRUE(step(*from_file, b, nullptr));
    }
    EXPECT_EQ(a.x, b.x);  // bit for bit
  }
}

TEST(SpringPredictorFile, BadFilesAreRefusedWithTheReason) {
  const SpringNetwork net = block_network(3, 3, 3, 0.01, 300.0, 0.1, true, 0.05);
  const SpringModelOptions o = opts(SpringSolver::sparse);
  SpringModel model = must_build(net, o);
  const auto good = temp_file("good.predictor");
  ASSERT_TRUE(save_predictor(good, model).ok());
  const std::string bytes = read_all(good);
  const auto bad = temp_file("bad.predictor");

  write_all(bad, bytes.substr(0, bytes.size() / 2));
  auto r = load_predictor(bad, net, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, bad.string() + ": truncated: " + std::to_string(bytes.size() / 2) +
                                   " bytes, expected " + std::to_string(bytes.size()));

  write_all(bad, bytes.substr(0, 20));
  r = load_predictor(bad, net, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, bad.string() + ": truncated: 20 bytes, shorter than the header");

  std::string flipped = bytes;
  flipped[predictor_file::kHeaderSize + (bytes.size() - predictor_file::kHeaderSize) / 2] ^= 0x40;
  write_all(bad, flipped);
  r = load_predictor(bad, net, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, bad.string() + ": corrupted: checksum mismatch");

  std::string magic = bytes;
  magic[0] = 'X';
  write_all(bad, magic);
  r = load_predictor(bad, net, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, bad.string() + ": not a palpate predictor file (bad magic)");

  std::string version = bytes;
  version[8] = 9;
  write_all(bad, version);
  r = load_predictor(bad, net, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, bad.string() + ": predictor file version 9, this palpate reads version 1");

  SpringNetwork moved = net;
  moved.rest(5, 1) += 1e-6;
  r = load_predictor(good, moved, o);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, good.string() + ": made for another mesh (27 vertices, mesh hash "))
      << r.error().message;

  SpringModelOptions other_dt = o;
  other_dt.dt = 0.002;
  r = load_predictor(good, net, other_dt);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, good.string() + ": made for other parameters: dt 0.001 s in the file, 0.002 s here");

  SpringModelOptions other_solver = o;
  other_solver.solver = SpringSolver::desbrun;
  r = load_predictor(good, net, other_solver);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, good.string() + ": made for other parameters: solver sparse in the file, desbrun here");

  SpringNetwork stiffer = net;
  stiffer.stiffness[3] *= 2;
  r = load_predictor(good, stiffer, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message,
            good.string() + ": made for other parameters: stiffness of spring 3 is 300 N/m in the file, 600 N/m here");

  SpringNetwork heavier = net;
  heavier.mass[7] *= 2;
  r = load_predictor(good, heavier, o);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "made for other parameters: mass of vertex 7")) << r.error().message;

  SpringNetwork unanchored = net;
  unanchored.anchors.pop_back();
  r = load_predictor(good, unanchored, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, good.string() + ": made for other parameters: anchors: 9 anchored vertices in the file, 8 here");

  SpringNetwork rewired = net;
  std::swap(rewired.springs[0], rewired.springs[1]);
  r = load_predictor(good, rewired, o);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "made for other parameters: topology: spring 0 joins")) << r.error().message;
}

TEST(SpringPredictorFile, PolicyRecomputesOrStops) {
  const SpringNetwork net = block_network(3, 3, 3, 0.01, 300.0, 0.1, true, 0.05);
  const SpringModelOptions o = opts(SpringSolver::sparse);
  const auto file = temp_file("policy.predictor");
  std::filesystem::remove(file);
  std::string note;
  // Missing: require_file stops, load_or_compute computes and writes it.
  auto m = build_spring_model(net, o, file, PredictorPolicy::require_file, &note);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().message, file.string() + ": no predictor file (predictor_policy: require_file)");
  m = build_spring_model(net, o, file, PredictorPolicy::load_or_compute, &note);
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE(std::filesystem::exists(file));
  EXPECT_TRUE(contains(note, "saved")) << note;
  m = build_spring_model(net, o, file, PredictorPolicy::require_file, &note);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(note, "loaded " + file.string());
  // Stale (other dt): require_file says why; load_or_compute recomputes over it.
  SpringModelOptions other = o;
  other.dt = 0.0005;
  m = build_spring_model(net, other, file, PredictorPolicy::require_file, &note);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().message, file.string() +
                                   ": made for other parameters: dt 0.001 s in the file, 0.00050000000000000001 s here "
                                   "(predictor_policy: require_file)");
  m = build_spring_model(net, other, file, PredictorPolicy::load_or_compute, &note);
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE(load_predictor(file, net, other).ok());
}

namespace {
// `bytes` with the double at `offset_from_end` doubles before the end set to `v`, and the
// checksum recomputed (an edit made by hand or by a tool, not a damaged file).
std::string edited(const std::string& bytes, size_t offset_from_end, double v) {
  std::string out = bytes;
  std::memcpy(out.data() + out.size() - 8 * offset_from_end, &v, 8);
  const std::uint64_t sum = predictor_file::checksum(
      reinterpret_cast<const unsigned char*>(out.data()) + predictor_file::kHeaderSize,
      out.size() - predictor_file::kHeaderSize);
  std::memcpy(out.data() + 24, &sum, 8);
  return out;
}
// The double `offset_from_end` doubles before the end of `bytes`.
double read_double(const std::string& bytes, size_t offset_from_end) {
  double v;
  std::memcpy(&v, bytes.data() + bytes.size() - 8 * offset_from_end, 8);
  return v;
}
}  // namespace

// A checksum anyone can recompute does not vouch for the numbers: a predictor whose payload is not
// finite, not symmetric or has a diagonal that is not positive is refused, saying where.
TEST(SpringPredictorFile, EditedPayloadWithAValidChecksumIsRefused) {
  const SpringNetwork net = block_network(3, 3, 3, 0.01, 300.0, 0.1, true, 0.05);
  const size_t n = net.size();
  {
    const SpringModelOptions o = opts(SpringSolver::desbrun);
    const auto good = temp_file("dense_edit.predictor");
    ASSERT_TRUE(save_predictor(good, must_build(net, o)).ok());
    const std::string bytes = read_all(good);
    const auto bad = temp_file("dense_bad.predictor");
    // The dense inverse is the payload's last n·n doubles, row-major: entry (i, j) is n·n − (i·n + j)
    // doubles from the end.
    auto at = [&](size_t i, size_t j) { return n * n - (i * n + j); };
    const std::pair<std::string, std::string> cases[] = {
        {edited(bytes, at(4, 1), std::nan("")), "the dense inverse's entry (4, 1) is not finite"},
        {edited(bytes, at(0, 0), std::nan("")), "the dense inverse's diagonal entry 0 is nan"},
        {edited(bytes, at(5, 5), -1e-3), "the dense inverse's diagonal entry 5 is -0.001; expected a positive number"},
        {edited(bytes, at(2, 7), 0.5), "the dense inverse is not symmetric at (7, 2)"},
    };
    for (const auto& [file, want] : cases) {
      write_all(bad, file);
      auto r = load_predictor(bad, net, o);
      ASSERT_FALSE(r.ok()) << want;
      EXPECT_TRUE(contains(r.error().message, bad.string() + ": corrupted: " + want)) << r.error().message;
    }
  }
  {
    const SpringModelOptions o = opts(SpringSolver::sparse);
    const auto good = temp_file("sparse_edit.predictor");
    ASSERT_TRUE(save_predictor(good, must_build(net, o)).ok());
    const std::string bytes = read_all(good);
    const auto bad = temp_file("sparse_bad.predictor");
    // The sparse factor ends with inv_diag (n doubles), after the nnz values.
    write_all(bad, edited(bytes, n - 3, 0.0));
    auto r = load_predictor(bad, net, o);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(contains(r.error().message, "the sparse factor's 1/D entry 3 is 0; expected a positive number"))
        << r.error().message;
    write_all(bad, edited(bytes, n + 1, std::numeric_limits<double>::infinity()));
    r = load_predictor(bad, net, o);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(contains(r.error().message, "the sparse factor's entry")) << r.error().message;
    EXPECT_TRUE(contains(r.error().message, "is not finite")) << r.error().message;
    // Finite, positive, inside its triangle, and wrong: a 1/D entry doubled, an entry of L changed
    // (the fuzzer's finding: a factor of another matrix passes every check of form).
    for (const std::string& file : {edited(bytes, n - 3, 2 * read_double(bytes, n - 3)), edited(bytes, n + 1, 0.25)}) {
      write_all(bad, file);
      r = load_predictor(bad, net, o);
      ASSERT_FALSE(r.ok());
      EXPECT_TRUE(contains(r.error().message, bad.string() + ": corrupted: the sparse factor is not this network's"))
          << r.error().message;
    }
  }
  {
    // A symmetric edit with a positive diagonal passes the dense checks of form; not the residual.
    const SpringModelOptions o = opts(SpringSolver::desbrun);
    const auto good = temp_file("dense_edit2.predictor");
    ASSERT_TRUE(save_predictor(good, must_build(net, o)).ok());
    const auto bad = temp_file("dense_bad2.predictor");
    auto at = [&](size_t i, size_t j) { return n * n - (i * n + j); };
    const std::string bytes = read_all(good);
    write_all(bad, edited(edited(bytes, at(3, 3), 1.5 * read_double(bytes, at(3, 3))), at(1, 1),
                          0.5 * read_double(bytes, at(1, 1))));
    auto r = load_predictor(bad, net, o);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(contains(r.error().message, bad.string() + ": corrupted: the dense inverse is not this network's"))
        << r.error().message;
  }
}

// The check behind those refusals: the network's own predictor solves A x = b to round-off, one of
// a network that differs only in its stiffness does not.
TEST(SpringPredictorFile, ResidualIsRoundOffOnlyForTheNetworksOwnPredictor) {
  const SpringNetwork soft = block_network(4, 3, 3, 0.01, 300.0, 0.1, true, 0.05);
  const SpringNetwork stiff = block_network(4, 3, 3, 0.01, 330.0, 0.1, true, 0.05);
  for (SpringSolver solver : {SpringSolver::desbrun, SpringSolver::sparse}) {
    const SpringModelOptions o = opts(solver);
    const SpringPredictor own = must_build(soft, o).predictor, other = must_build(stiff, o).predictor;
    const double good = spring::predictor_residual(soft, o, own), bad = spring::predictor_residual(soft, o, other);
    EXPECT_LT(good, 1e-13) << static_cast<int>(solver);
    EXPECT_GT(bad, 1e-4) << static_cast<int>(solver);
    EXPECT_LT(spring::predictor_residual(stiff, o, other), 1e-13) << static_cast<int>(solver);
  }
}
