// arap-bench: time and convergence of the ARAP solver on procedural meshes
// and given mesh / scenario files, next to CGAL's Surface_mesh_deformation
// when CGAL was found at configure time. Writes results.md and results.json
// (rewritten after every mesh, so an interrupted run keeps what it measured).
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "methods.h"
#include "arap/solver.h"
#include "arap/version.h"
#include "band.h"
#include "bench_cases.h"
#include "cpu_clock.h"
#include "settle.h"
#ifdef ARAP_BENCH_HAVE_CGAL
#include "cgal_arap.h"
#endif

namespace {

using nlohmann::json;

struct Args {
  int min_vertices = 1000, max_vertices = 1000000;
  std::vector<std::string> shapes = {"sphere", "bar"};
  std::vector<std::string> files;
  int iterations = 200;
  std::vector<arap::Weights> weights = {arap::Weights::Cotan};
  std::vector<int> threads = {1};
  arap::InitialGuess init = arap::InitialGuess::Laplacian;
  int anderson = 0;
  bool cgal = true;
  int cgal_max_vertices = 300000, cgal_iterations = 20;
  double repeat_seconds = 3;
  int bind_pairs = 7;  // alternated binds of ours and CGAL's preprocess, for the bind ratio
  std::string output_dir = "results";
  std::vector<int> sizes;  // explicit procedural sizes instead of doubling
  bool time_to_band = false;
  int band_iterations = 2000;
  int band_extend = 0;
  double band_cap = 0;
  double settle_step = 0;  // > 0: the settle-after-a-step mode
  int settle_repeats = 3;
};

const char* kUsage = R"(usage: arap-bench [options] [mesh.off|.obj|.ply|scenario.json ...]
  --min-vertices N       smallest procedural mesh (default 1000)
  --max-vertices N       largest procedural mesh (default 1000000); sizes double from the smallest
  --shapes LIST          procedural shapes: sphere,bar (default both; "none" for files only)
  --iterations N         iterations per solve (default 200; the reference energy is the last one)
  --weights LIST         cotan,cotan-clamped,uniform (default cotan)
  --threads LIST         thread counts, e.g. 1,2 (default 1); counts after the first time the first
                         weight only, over 30 iterations (their energies equal the first count's)
  --init NAME            first guess: laplacian (default, as CGAL's first iteration), naive, differential
  --anderson M           also run with Anderson acceleration, window M (default 0: off)
  --no-cgal              skip CGAL
  --cgal-max-vertices N  largest mesh given to CGAL (default 300000)
  --cgal-iterations N    CGAL iterations (default 20)
  --bind-pairs K         after the runs, K binds of ours and K CGAL preprocesses alternated (CPU time of the
                         thread, the first of each pair switching sides), whose median ratio is the ours/CGAL
                         bind column (default 7; 0: the medians of the runs' binds instead)
  --repeat-seconds S     repeat each measurement (up to 5 times) while its runs took less than S
                         seconds in all, and keep the run with the lowest median iteration (default 3)
  --output-dir DIR       where results.md and results.json go (default ./results)
  --sizes LIST           procedural sizes, e.g. 100000,250000 (instead of doubling from --min-vertices)
  --time-to-band         instead of the per-iteration tables: CPU time of each method (local-global,
                         anderson-5, quasi-newton, CGAL) from a cold start into the band
                         E <= E* + 1e-3 |E*|, E* the lowest energy any reaches in --band-iterations;
                         writes band.md and band.json
  --band-iterations N    the budget that finds E* (default 2000)
  --band-extend N        local-global and quasi-newton runs not in the band within the budget go on
                         (resumed exactly, by warm starts) up to N iterations to find when they enter
                         it (marked * in band.md; default 0: off)
  --settle-step F        instead of the per-iteration tables: each method settles the case's pose with the
                         default options, the handles move F times the longest side further along their
                         motion (e.g. 0.05), and the warm-started settle of that step is measured: iterations,
                         median CPU ms, in the band of the moved pose or not; writes settle.md and settle.json
  --settle-repeats K     timed settles per method (default 3)
  --band-cap R           the other methods' extended runs, and CGAL, stop once their CPU time passes R
                         times quasi-newton's time to the band ("> t", so the ratio is below 1/R), and a
                         solve to the band that alone takes longer is timed once (default 0: off)
)";

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

Args parse_args(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--help" || flag == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (flag == "--min-vertices") {
      a.min_vertices = std::stoi(value());
    } else if (flag == "--max-vertices") {
      a.max_vertices = std::stoi(value());
    } else if (flag == "--shapes") {
      a.shapes = split(value());
      if (a.shapes == std::vector<std::string>{"none"}) a.shapes.clear();
    } else if (flag == "--iterations") {
      a.iterations = std::max(1, std::stoi(value()));
    } else if (flag == "--weights") {
      a.weights.clear();
      for (const auto& w : split(value())) a.weights.push_back(arap::parse_weights(w));
    } else if (flag == "--threads") {
      a.threads.clear();
      for (const auto& t : split(value())) a.threads.push_back(std::max(1, std::stoi(t)));
    } else if (flag == "--init") {
      a.init = arap::parse_initial_guess(value());
    } else if (flag == "--anderson") {
      a.anderson = std::stoi(value());
    } else if (flag == "--no-cgal") {
      a.cgal = false;
    } else if (flag == "--cgal-max-vertices") {
      a.cgal_max_vertices = std::stoi(value());
    } else if (flag == "--cgal-iterations") {
      a.cgal_iterations = std::max(1, std::stoi(value()));
    } else if (flag == "--bind-pairs") {
      a.bind_pairs = std::max(0, std::stoi(value()));
    } else if (flag == "--repeat-seconds") {
      a.repeat_seconds = std::stod(value());
    } else if (flag == "--output-dir") {
      a.output_dir = value();
    } else if (flag == "--sizes") {
      for (const auto& v : split(value())) a.sizes.push_back(std::stoi(v));
    } else if (flag == "--time-to-band") {
      a.time_to_band = true;
    } else if (flag == "--band-iterations") {
      a.band_iterations = std::max(1, std::stoi(value()));
    } else if (flag == "--band-extend") {
      a.band_extend = std::max(0, std::stoi(value()));
    } else if (flag == "--settle-step") {
      a.settle_step = std::stod(value());
      if (!(a.settle_step > 0)) throw std::runtime_error("--settle-step needs a fraction > 0");
    } else if (flag == "--settle-repeats") {
      a.settle_repeats = std::max(1, std::stoi(value()));
    } else if (flag == "--band-cap") {
      a.band_cap = std::max(0.0, std::stod(value()));
    } else if (!flag.empty() && flag[0] == '-') {
      throw std::runtime_error("unknown option " + flag + "\n" + kUsage);
    } else {
      a.files.push_back(flag);
    }
  }
  if (a.weights.empty() || a.threads.empty()) throw std::runtime_error("--weights and --threads need values");
  return a;
}

// ---- peak memory ------------------------------------------------------------
// VmHWM (peak resident set) only grows during a process; Linux resets it to
// the current RSS when "5" is written to /proc/self/clear_refs. Each
// measurement returns freed memory to the system (malloc_trim), resets the
// peak, and reports VmHWM - VmRSS at the start: the extra resident memory the
// measured code needed at its peak.
long status_kb(const char* field) {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(field, 0) == 0) return std::atol(line.c_str() + std::string(field).size() + 1);
  return -1;
}

struct PeakMemory {
  long baseline_kb = 0;
  bool reset = false;
  void start() {
    malloc_trim(0);
    std::ofstream clear("/proc/self/clear_refs");
    reset = static_cast<bool>(clear << "5" << std::flush);
    baseline_kb = status_kb("VmRSS:");
  }
  // MiB above the start; without the reset, the process's peak so far minus the start.
  double mib() const { return (status_kb("VmHWM:") - baseline_kb) / 1024.0; }
};

bool peak_reset_works() {
  PeakMemory probe;
  probe.start();
  return probe.reset;
}

// ---- small statistics --------------------------------------------------------
double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t lo = static_cast<size_t>(pos);
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - lo) * (v[hi] - v[lo]);
}

json spread(const std::vector<double>& ms) {
  return {{"median", quantile(ms, 0.5)}, {"min", quantile(ms, 0)}, {"p25", quantile(ms, 0.25)},
          {"p75", quantile(ms, 0.75)},   {"max", quantile(ms, 1)}};
}

// Energy after k iterations (1-based) or null when the run was shorter.
json energy_after(const std::vector<double>& energy, int k) {
  return k <= static_cast<int>(energy.size()) ? json(energy[k - 1]) : json(nullptr);
}

// The first k with energy[k-1] - reference <= 1e-3 |energy[0]|, or 0 if none.
int iterations_to_reach(const std::vector<double>& energy, double reference, double first) {
  for (size_t k = 0; k < energy.size(); ++k)
    if (energy[k] - reference <= 1e-3 * std::abs(first)) return static_cast<int>(k) + 1;
  return 0;
}

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// Runs `measure` (returning a run with "iteration_ms") up to 5 times while
// the runs took less than `seconds` in all; keeps the run with the lowest
// median iteration time, so that a burst of load on a shared machine does not
// decide the row. Small meshes get several tries, large ones one.
template <class Measure>
json best_of(double seconds, Measure measure) {
  json best;
  int runs = 0;
  // The one-off set-up of every run (ours: bind; CGAL: preprocess), whose median is compared.
  std::vector<double> setup_ms;
  const auto start = Clock::now();
  do {
    json r = measure();
    ++runs;
    if (!r.contains("iteration_ms")) return r;  // an error
    setup_ms.push_back(r.contains("bind_ms") ? r["bind_ms"].get<double>() : r["preprocess_ms"].get<double>());
    if (best.is_null() || r["iteration_ms"]["median"].get<double>() < best["iteration_ms"]["median"].get<double>())
      best = std::move(r);
  } while (runs < 5 && ms_since(start) < 1e3 * seconds);
  best["repetitions"] = runs;
  const std::string key = best.contains("bind_ms") ? "bind_ms" : "preprocess_ms";
  best[key + "_all"] = setup_ms;
  best[key + "_median"] = quantile(setup_ms, 0.5);
  return best;
}

// ---- one run of our solver ------------------------------------------------------
// timing_only: a short run (kTimingIterations) for the extra thread counts,
// whose energies are those of the full single-count run.
constexpr int kTimingIterations = 30;

json run_ours(const bench::Case& c, arap::Weights weights, int threads, int anderson, bool timing_only,
              const Args& args) {
  arap::Options options = bench::surface_options();
  // Iterations of the same algorithm as CGAL's: the textbook alternation (or Anderson's on it).
  options.method = anderson > 0 ? arap::Method::Anderson : arap::Method::LocalGlobal;
  options.weights = weights;
  options.init = args.init;
  options.tolerance = 0;
  options.threads = threads;
  options.anderson_window = anderson;

  PeakMemory memory;
  memory.start();
  arap::Solver solver;
  const auto t = Clock::now();
  const double bind_cpu_start = bench::process_cpu_ms();
  solver.bind(c.rest, c.triangles, c.constrained, options);
  const double bind_cpu_ms = bench::process_cpu_ms() - bind_cpu_start;
  const double bind_wall_ms = ms_since(t);
  // Warm-up: the first guess and one local step, so that the measured solve
  // does not pay for starting OpenMP's threads or first-touching its buffers.
  solver.options().max_iterations = 0;
  solver.solve(c.targets);
  solver.options().max_iterations = timing_only ? std::min(args.iterations, kTimingIterations) : args.iterations;
  const double solve_cpu_start = bench::process_cpu_ms();
  const arap::SolveStats st = solver.solve(c.targets);
  const double solve_cpu_ms = bench::process_cpu_ms() - solve_cpu_start;
  const double peak_mib = memory.mib();

  const int n = st.iterations;
  // cumulative time at which each energy was reached, from the start of solve()
  const double first_local_ms = st.rotation_ms / (n + 1);
  std::vector<double> elapsed;
  double clock = st.init_ms + first_local_ms;
  for (double ms : st.iteration_ms) elapsed.push_back(clock += ms);

  const double reference = timing_only ? NAN : st.energy.back();
  const int k = timing_only ? 0 : iterations_to_reach(st.energy, reference, st.energy.front());
  json r = {{"weights", arap::to_string(weights)},
            {"threads", threads},
            {"anderson", anderson},
            {"init", arap::to_string(args.init)},
            {"bind_ms", solver.bind_stats().total_ms},
            {"bind_mesh_ms", solver.bind_stats().mesh_ms},
            {"bind_ordering_ms", solver.bind_stats().ordering_ms},
            {"bind_factor_ms", solver.bind_stats().factor_ms},
            {"bind_wall_ms", bind_wall_ms},
            {"bind_cpu_ms", bind_cpu_ms},  // CPU time of the process (with threads > 1 the bind's halves run on two)
            // CPU time of the process (all threads) over the timed solve, per iteration
            {"iteration_cpu_ms", n ? json(solve_cpu_ms / n) : json(nullptr)},
            {"factor_nonzeros", solver.factor_nonzeros()},
            {"init_ms", st.init_ms},
            {"first_local_ms", first_local_ms},
            {"iterations", n},
            {"iteration_ms", spread(st.iteration_ms)},
            {"rotation_ms_per_iteration", st.rotation_ms / (n + 1)},
            {"rhs_ms_per_iteration", st.rhs_ms / n},
            {"solve_ms_per_iteration", st.linear_solve_ms / n},
            {"peak_mib", peak_mib},
            {"peak_mib_reset", memory.reset},
            {"initial_energy", st.initial_energy},
            {"energy_after", {{"1", energy_after(st.energy, 1)},
                              {"5", energy_after(st.energy, 5)},
                              {"20", energy_after(st.energy, 20)},
                              {"100", energy_after(st.energy, 100)}}},
            {"timing_only", timing_only},
            {"reference_energy", timing_only ? json(nullptr) : json(reference)},
            {"reference_iterations", n},
            {"iterations_to_1e-3", k},
            {"ms_to_1e-3", k ? json(elapsed[k - 1]) : json(nullptr)},
            {"anderson_rejections", st.anderson_rejections},
            {"energy", st.energy},
            {"elapsed_ms", elapsed},
            {"iteration_ms_all", st.iteration_ms}};
  return r;
}

#ifdef ARAP_BENCH_HAVE_CGAL
// CGAL on the same problem; its energies are evaluated with our energy and
// cotan-clamped weights (CGAL's weights), outside the timed calls.
json run_cgal(const bench::Case& c, const Args& args, double reference_clamped) {
  arap::Options options = bench::surface_options();
  options.weights = arap::Weights::CotanClamped;
  arap::Solver evaluator;
  evaluator.bind(c.rest, c.triangles, c.constrained, options);

  std::vector<double> energy;
  PeakMemory memory;
  memory.start();
  const bench::CgalResult res =
      bench::run_cgal_arap(c.rest, c.triangles, c.constrained, c.targets, args.cgal_iterations,
                           [&](const arap::Points& p) { energy.push_back(evaluator.energy(p)); });
  const double peak_mib = memory.mib();  // includes the few MiB of the energy evaluation
  if (!res.ok) return {{"error", res.error}};

  std::vector<double> elapsed;
  double clock = 0;
  for (double ms : res.iteration_ms) elapsed.push_back(clock += ms);
  json r = {{"build_ms", res.build_ms},
            {"preprocess_ms", res.preprocess_ms},
            {"preprocess_cpu_ms", res.preprocess_cpu_ms},
            {"iterations", res.iteration_ms.size()},
            {"iteration_ms", spread(res.iteration_ms)},
            {"peak_mib", peak_mib},
            {"energy_after", {{"1", energy_after(energy, 1)}, {"5", energy_after(energy, 5)},
                              {"20", energy_after(energy, 20)}, {"100", energy_after(energy, 100)}}},
            {"energy", energy},
            {"elapsed_ms", elapsed},
            {"iteration_ms_all", res.iteration_ms}};
  if (std::isfinite(reference_clamped) && !energy.empty()) {
    const int k = iterations_to_reach(energy, reference_clamped, energy.front());
    r["iterations_to_1e-3"] = k;
    r["ms_to_1e-3"] = k ? json(elapsed[k - 1]) : json(nullptr);
  }
  return r;
}
#endif

#ifdef ARAP_BENCH_HAVE_CGAL
// Our bind (a fresh solver, the first weights, one thread) and CGAL's
// preprocess, `pairs` times each, alternated so that a change of the machine's
// speed during the run touches both sides alike: the median of the pairs'
// ratios of CPU time of the thread, with every sample kept.
json bind_pairs(const bench::Case& c, arap::Weights weights, const Args& args) {
  arap::Options options = bench::surface_options();
  options.weights = weights;
  options.init = args.init;
  std::vector<double> ours_ms, cgal_ms, ratio;
  // Each side starts from trimmed memory, as the runs do (PeakMemory::start): both pay their page faults.
  auto time_ours = [&] {
    malloc_trim(0);
    arap::Solver solver;
    const double start = bench::thread_cpu_ms();
    solver.bind(c.rest, c.triangles, c.constrained, options);
    return bench::thread_cpu_ms() - start;
  };
  auto time_cgal = [&] {
    malloc_trim(0);
    const bench::CgalResult res = bench::run_cgal_arap(c.rest, c.triangles, c.constrained, c.targets, 0, {});
    if (!res.ok) throw std::runtime_error("CGAL: " + res.error);
    return res.preprocess_cpu_ms;
  };
  for (int k = 0; k < args.bind_pairs; ++k) {
    double ours, cgal;
    if (k % 2 == 0) {
      ours = time_ours();
      cgal = time_cgal();
    } else {
      cgal = time_cgal();
      ours = time_ours();
    }
    ours_ms.push_back(ours), cgal_ms.push_back(cgal), ratio.push_back(ours / cgal);
  }
  return {{"weights", arap::to_string(weights)},
          {"ours_cpu_ms", ours_ms},
          {"cgal_cpu_ms", cgal_ms},
          {"ratio", ratio},
          {"ratio_median", quantile(ratio, 0.5)},
          {"ratio_min", *std::min_element(ratio.begin(), ratio.end())},
          {"ratio_max", *std::max_element(ratio.begin(), ratio.end())}};
}
#endif

// ---- output ----------------------------------------------------------------------
std::string fmt(const json& v, const char* spec = "%.3g") {
  if (v.is_null()) return "–";
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, v.get<double>());
  return buf;
}

// The ours/CGAL bind column: the alternated pairs' median ratio (CPU time)
// for the row of the pairs' weights at one thread, else the medians of the
// runs' binds (wall time) over the median of CGAL's preprocesses.
std::string bind_ratio(const json& mesh, const json& run, const json& cgal) {
  const json& pairs = mesh.contains("bind_pairs") ? mesh["bind_pairs"] : json();
  if (pairs.is_object() && run["threads"].get<int>() == 1 && run["anderson"].get<int>() == 0 &&
      run["weights"] == pairs["weights"])
    return fmt(pairs["ratio_median"], "%.3f") + " [" + fmt(pairs["ratio_min"], "%.2f") + "–" +
           fmt(pairs["ratio_max"], "%.2f") + "]";
  return fmt(run["bind_ms_median"].get<double>() / cgal["preprocess_ms_median"].get<double>(), "%.2f");
}

// "61 / 9 / 30": shares of the mean iteration spent in the local step, the
// right-hand side and the triangular solves.
std::string split_percent(const json& run) {
  const double rot = run["rotation_ms_per_iteration"], rhs = run["rhs_ms_per_iteration"],
               solve = run["solve_ms_per_iteration"], total = rot + rhs + solve;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.0f / %.0f / %.0f", 100 * rot / total, 100 * rhs / total, 100 * solve / total);
  return buf;
}

// "10 / 70": shares of bind in the fill-reducing ordering and the factorization.
std::string bind_percent(const json& run) {
  const double total = run["bind_ms"];
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.0f / %.0f", 100 * run["bind_ordering_ms"].get<double>() / total,
                100 * run["bind_factor_ms"].get<double>() / total);
  return buf;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

void write_results(const json& doc, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "results.json") << doc.dump(1) << "\n";

  std::ofstream md(dir / "results.md");
  const json& set = doc["settings"];
  md << "# ARAP benchmark\n\n"
     << "arap " << doc["arap_version"].get<std::string>() << ", " << doc["machine"]["cpu"].get<std::string>() << ", "
     << doc["machine"]["compiler"].get<std::string>() << ", " << doc["date"].get<std::string>() << ".\n\n"
     << "- Scenario of procedural meshes and plain mesh files: bottom fifth (by the longest bounding-box axis) "
        "fixed, top 5 % moved sideways by 0.3 h. Scenario files: their own constraints.\n"
     << "- Ours: plain local/global iterations (as CGAL's), first guess `" << set["init"].get<std::string>() << "`, "
     << set["iterations"].get<int>()
     << " iterations per solve after a warm-up solve (first guess only); the energy after the last iteration is the "
        "reference E_ref. Thread counts after the first time the first weights over 30 iterations.\n"
     << "- Each measurement (ours and CGAL) is repeated up to 5 times while its runs took less than "
     << set["repeat_seconds"].get<double>()
     << " s in all; the row is the run with the lowest median iteration "
        "time (small meshes get several tries, large ones one); ours/CGAL bind: after the runs, our bind "
        "(first weights, one thread, a fresh solver) and CGAL's prep alternate --bind-pairs times each (CPU time of "
        "the thread, each from trimmed memory); the column is the median [min–max] of the pairs' ratios "
        "(bind_pairs in results.json), or with no pairs the medians of the runs' bind and prep (wall).\n"
     << "- Times in ms. bind: total, with the shares of the fill-reducing ordering and of the numeric "
        "factorization (the rest: checks, weights, Laplacian). iteration: median [min–max] over all iterations; rot / "
        "rhs / solve: shares of the mean "
        "iteration in the local step (with its energy), the right-hand side and the triangular solves (per-step "
        "means in results.json).\n"
     << "- peak MiB: extra resident memory at the peak of bind + solve, i.e. VmHWM minus VmRSS before, the peak "
        "being reset through /proc/self/clear_refs (\"5\") before each measurement"
     << (doc["peak_reset_works"].get<bool>() ? "" : " — NOT available here, so the peak is the process's so far")
     << ". CGAL MiB: the same for building its Surface_mesh and deforming.\n"
     << "- CGAL: Surface_mesh_deformation with ORIGINAL_ARAP and its defaults (cotangent weights with negative "
        "cotangents clamped to 0, i.e. our cotan-clamped; SparseLU with COLAMD); whole mesh as ROI, every "
        "constrained vertex a control vertex (fixed ones target their rest position). prep = ROI/control "
        "insertion + weights + factorization; iteration = one deform(1, 0) call, "
     << set["cgal_iterations"].get<int>() << " of them, on meshes up to " << set["cgal_max_vertices"].get<int>()
     << " vertices. Its k-th iteration does the work of our first guess plus k-1 iterations.\n\n";

  md << "## Time\n\n"
     << "| mesh | V | weights | thr | bind (order / factor %) | guess | iteration | rot / rhs / solve % | peak MiB | "
        "CGAL prep | "
        "CGAL iteration | CGAL MiB | ours/CGAL iter | ours/CGAL bind |\n"
     << "|---|---:|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|\n";
  for (const json& m : doc["meshes"]) {
    const json& cg = m["cgal"];
    const bool has_cgal = cg.is_object() && cg.contains("iteration_ms");
    for (const json& r : m["runs"]) {
      const json& it = r["iteration_ms"];
      md << "| " << m["name"].get<std::string>() << " | " << m["vertices"].get<long>() << " | "
         << r["weights"].get<std::string>()
         << (r["anderson"].get<int>() ? " +AA" + std::to_string(r["anderson"].get<int>()) : "") << " | "
         << r["threads"].get<int>() << " | " << fmt(r["bind_ms"]) << " (" << bind_percent(r) << ") | "
         << fmt(r["init_ms"]) << " | " << fmt(it["median"]) << " [" << fmt(it["min"]) << "–" << fmt(it["max"]) << "] | "
         << split_percent(r) << " | " << fmt(r["peak_mib"]) << " | ";
      if (has_cgal) {
        const json& ci = cg["iteration_ms"];
        md << fmt(cg["preprocess_ms"]) << " | " << fmt(ci["median"]) << " [" << fmt(ci["min"]) << "–"
           << fmt(ci["max"]) << "] | " << fmt(cg["peak_mib"]) << " | "
           << fmt(it["median"].get<double>() / ci["median"].get<double>(), "%.2f") << " | "
           << bind_ratio(m, r, cg) << " |\n";
      } else {
        md << (cg.is_object() && cg.contains("error") ? "error: " + cg["error"].get<std::string>() : "–")
           << " | – | – | – | – |\n";
      }
    }
  }

  md << "\n## Convergence\n\n"
     << "Energy E (Sorkine & Alexa, optimal rotations, the row's weights) after k iterations; E_ref = after the "
        "last iteration. \"to 1e-3\": iterations and ms from the start of solve() until E - E_ref <= 1e-3 |E_1|. "
        "CGAL energies are computed with our energy and cotan-clamped weights, so compare them with the "
        "cotan-clamped rows (CGAL after k iterations ~ ours after k-1).\n\n"
     << "| mesh | V | weights | thr | E guess | E1 | E5 | E20 | E100 | E_ref | to 1e-3 (it) | to 1e-3 (ms) | "
        "CGAL E1 | CGAL E5 | CGAL E20 | CGAL to 1e-3 (it / ms) |\n"
     << "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const json& m : doc["meshes"]) {
    const json& cg = m["cgal"];
    for (const json& r : m["runs"]) {
      const json& e = r["energy_after"];
      if (r["timing_only"].get<bool>()) continue;
      md << "| " << m["name"].get<std::string>() << " | " << m["vertices"].get<long>() << " | "
         << r["weights"].get<std::string>()
         << (r["anderson"].get<int>() ? " +AA" + std::to_string(r["anderson"].get<int>()) : "") << " | "
         << r["threads"].get<int>() << " | " << fmt(r["initial_energy"], "%.6g") << " | " << fmt(e["1"], "%.6g")
         << " | " << fmt(e["5"], "%.6g") << " | " << fmt(e["20"], "%.6g") << " | " << fmt(e["100"], "%.6g") << " | "
         << fmt(r["reference_energy"], "%.6g") << " | "
         << (r["iterations_to_1e-3"].get<int>() ? std::to_string(r["iterations_to_1e-3"].get<int>()) : "–") << " | "
         << fmt(r["ms_to_1e-3"]) << " | ";
      const bool comparable = cg.is_object() && cg.contains("energy_after") && r["weights"] == "cotan-clamped";
      if (comparable) {
        const json& ce = cg["energy_after"];
        const int k = cg.value("iterations_to_1e-3", 0);
        md << fmt(ce["1"], "%.6g") << " | " << fmt(ce["5"], "%.6g") << " | " << fmt(ce["20"], "%.6g") << " | "
           << (k ? std::to_string(k) + " / " + fmt(cg["ms_to_1e-3"])
                 : "> " + std::to_string(cg["iterations"].get<int>()))
           << " |\n";
      } else {
        md << "– | – | – | – |\n";
      }
    }
  }
}

// Writes <stem>.json and opens <stem>.md with its title and the version, machine and date line.
std::ofstream start_results(const json& doc, const std::filesystem::path& dir, const std::string& stem,
                            const char* title) {
  std::filesystem::create_directories(dir);
  std::ofstream(dir / (stem + ".json")) << doc.dump(1) << "\n";
  std::ofstream md(dir / (stem + ".md"));
  md << "# " << title << "\n\n"
     << "arap " << doc["arap_version"].get<std::string>() << ", " << doc["machine"]["cpu"].get<std::string>() << ", "
     << doc["date"].get<std::string>() << ".\n\n";
  return md;
}

void write_band_results(const json& doc, const std::filesystem::path& dir) {
  std::ofstream md = start_results(doc, dir, "band", "Time to the band");
  md << "Cold start (naive guess, cotan-clamped weights, one thread). E* = the lowest energy any method reaches in "
     << doc["settings"]["band_iterations"].get<int>()
     << " iterations (each stops early only once its energy no longer moves, relative change <= 1e-14); the band "
        "is E <= E* + 1e-3 |E*|. Cells: iterations to the band / median CPU ms (CLOCK_THREAD_CPUTIME_ID) of 3 cold "
        "solves that run exactly that many iterations (bind excluded); \"> t\": not in the band within the budget, "
        "t = the budget's CPU time (the reference run); \"*\": entered the band only after the budget, found by "
        "resuming the reference run (warm starts continue local-global and quasi-newton exactly) in 100-iteration "
        "chunks, up to --band-extend iterations; its CPU time is the reference run's plus the chunks' (the last "
        "one pro rata). CGAL: the sum of its deform(1, 0) calls' CPU time (one run). Defaults: "
        "quasi-newton with the library's default tolerance (1e-6) and cap.";
  const double cap = doc["settings"]["band_cap"].get<double>();
  if (cap > 0)
    md << " With --band-cap " << cap << ": the resumed runs and CGAL stop once their CPU time passes " << cap
       << "x quasi-newton's time to the band (\"> t\" then bounds the ratio below 1/" << cap
       << "), and a solve to the band that alone takes longer than that is timed once.";
  md << "\n\n" << bench::band_table(doc["meshes"]);
}

void write_settle_results(const json& doc, const std::filesystem::path& dir) {
  std::ofstream md = start_results(doc, dir, "settle", "The settle after a step");
  md << "Each method binds with the default options (one thread), settles the case's pose, then the handles move "
     << doc["settings"]["settle_step"].get<double>()
     << " times the bounding box's longest side further along their motion and it settles again, warm-started "
        "(as Live and Auto mode do), to the default tolerance stop. Cells: that settle's iterations / the first "
        "iteration in the band (\"-\": none) / median CPU ms (CLOCK_THREAD_CPUTIME_ID) of "
     << doc["settings"]["settle_repeats"].get<int>()
     << " / in the band E <= E* + 1e-3 |E*| of the moved pose, E* found by quasi-newton resumed from the lowest "
        "settle until its energy no longer moves; \"(cap)\": stopped by the iteration cap. Ratios: CPU ms over "
        "quasi-newton's, same run.\n\n"
     << bench::settle_table(doc["meshes"]);
}

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Args args = parse_args(argc, argv);

    // What to measure: procedural sizes first, then the files, in the order given.
    std::vector<std::pair<std::string, int>> procedural;
    for (const auto& shape : args.shapes)
      for (int size : args.sizes) procedural.emplace_back(shape, size);
    for (const auto& shape : args.shapes)
      for (long target = args.min_vertices; args.sizes.empty(); target *= 2) {
        procedural.emplace_back(shape, static_cast<int>(std::min<long>(target, args.max_vertices)));
        if (target >= args.max_vertices) break;
      }
    std::sort(procedural.begin(), procedural.end(),
              [](const auto& a, const auto& b) { return std::tie(a.second, a.first) < std::tie(b.second, b.first); });

    json doc = {{"arap_version", arap::version()},
                {"date", now_utc()},
                {"machine", {{"cpu", cpu_model()}, {"compiler", "gcc " __VERSION__}}},
                {"settings",
                 {{"iterations", args.iterations},
                  {"init", arap::to_string(args.init)},
                  {"threads", args.threads},
                  {"cgal_max_vertices", args.cgal_max_vertices},
                  {"cgal_iterations", args.cgal_iterations},
                  {"repeat_seconds", args.repeat_seconds},
                  {"band_iterations", args.band_iterations},
                  {"band_extend", args.band_extend},
                  {"band_cap", args.band_cap},
                  {"settle_step", args.settle_step},
                  {"settle_repeats", args.settle_repeats}}},
                {"peak_reset_works", peak_reset_works()},
#ifdef ARAP_BENCH_HAVE_CGAL
                {"cgal_available", true},
#else
                {"cgal_available", false},
#endif
                {"meshes", json::array()}};

    const size_t total = procedural.size() + args.files.size();
    for (size_t index = 0; index < total; ++index) {
      bench::Case c = index < procedural.size()
                          ? bench::procedural_case(procedural[index].first, procedural[index].second)
                          : bench::file_case(args.files[index - procedural.size()]);
      std::cerr << "[" << index + 1 << "/" << total << "] " << c.name << ": " << c.rest.rows() << " vertices, "
                << c.constrained.size() << " constrained" << std::endl;
      if (args.settle_step > 0) {
        bench::SettleSettings settle;
        settle.step = args.settle_step;
        settle.repeats = args.settle_repeats;
        doc["meshes"].push_back(bench::settle_after_step(c, settle));
        write_settle_results(doc, args.output_dir);
        continue;
      }
      if (args.time_to_band) {
        bench::BandSettings band;
        band.reference_iterations = args.band_iterations;
        band.extend_iterations = args.band_extend;
        band.cap_ratio = args.band_cap;
        band.cgal = args.cgal;
        band.cgal_max_vertices = args.cgal_max_vertices;
        doc["meshes"].push_back(bench::time_to_band(c, band));
        write_band_results(doc, args.output_dir);
        continue;
      }
      json m = {{"name", c.name},
                {"source", c.source},
                {"vertices", c.rest.rows()},
                {"triangles", c.triangles.rows()},
                {"fixed", c.fixed_count},
                {"handles", static_cast<long>(c.constrained.size()) - c.fixed_count},
                {"runs", json::array()},
                {"cgal", nullptr}};

      [[maybe_unused]] double reference_clamped = NAN;  // read only when CGAL is built in
      // Every weight (and Anderson) at the first thread count; the other
      // thread counts time the first weight only.
      for (int threads : args.threads)
        for (arap::Weights w : args.weights) {
          const bool main_count = threads == args.threads.front();
          if (!main_count && w != args.weights.front()) continue;
          std::vector<int> windows = {0};
          if (args.anderson > 0 && main_count) windows.push_back(args.anderson);
          for (int anderson : windows) {
            json r = best_of(args.repeat_seconds, [&] { return run_ours(c, w, threads, anderson, !main_count, args); });
            std::cerr << "  ours " << r["weights"].get<std::string>() << (anderson ? " +AA" : "") << " x" << threads
                      << ": bind " << fmt(r["bind_ms"]) << " ms, iteration " << fmt(r["iteration_ms"]["median"])
                      << " ms, E_ref " << fmt(r["reference_energy"], "%.6g") << std::endl;
            if (w == arap::Weights::CotanClamped && !anderson && main_count)
              reference_clamped = r["reference_energy"].get<double>();
            m["runs"].push_back(std::move(r));
          }
        }

#ifdef ARAP_BENCH_HAVE_CGAL
      if (args.cgal && c.rest.rows() <= args.cgal_max_vertices) {
        m["cgal"] = best_of(args.repeat_seconds, [&] { return run_cgal(c, args, reference_clamped); });
        if (m["cgal"].contains("error"))
          std::cerr << "  CGAL: " << m["cgal"]["error"].get<std::string>() << std::endl;
        else
          std::cerr << "  CGAL: preprocess " << fmt(m["cgal"]["preprocess_ms"]) << " ms, iteration "
                    << fmt(m["cgal"]["iteration_ms"]["median"]) << " ms" << std::endl;
        if (args.bind_pairs > 0 && !m["cgal"].contains("error")) {
          m["bind_pairs"] = bind_pairs(c, args.weights.front(), args);
          std::cerr << "  bind pairs: ours/CGAL " << fmt(m["bind_pairs"]["ratio_median"], "%.3f") << " ["
                    << fmt(m["bind_pairs"]["ratio_min"], "%.3f") << "–" << fmt(m["bind_pairs"]["ratio_max"], "%.3f")
                    << "]" << std::endl;
        }
      }
#endif
      doc["meshes"].push_back(std::move(m));
      write_results(doc, args.output_dir);
    }
    const char* stem = args.settle_step > 0 ? "settle" : args.time_to_band ? "band" : "results";
    std::cerr << "wrote " << (std::filesystem::path(args.output_dir) / stem).string() << ".md and " << stem
              << ".json" << std::endl;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "arap-bench: " << e.what() << std::endl;
    return 1;
  }
}
