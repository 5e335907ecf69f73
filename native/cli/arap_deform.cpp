// arap-deform: deform a mesh file with constraints from a scenario JSON or
// from index files, write the result (and a JSON report). See deform_usage().
#include <time.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "arap/errors.h"
#include "arap/io/mesh_io.h"
#include "arap/io/polygons.h"
#include "arap/io/scenario.h"
#include "arap/solver.h"
#include "arap/tools/quality.h"
#include "deform_args.h"
#include "deform_report.h"

namespace {

using namespace arap;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// CPU time of this thread: comparable between runs on a busy machine, unlike wall time.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

// A sibling of `path` with the same extension, renamed over it once complete,
// so that a failed run never leaves a partial or stale file behind.
std::string temp_path_for(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  return (p.parent_path() / ("." + std::to_string(::getpid()) + ".arap-tmp." + p.filename().string())).string();
}

// Handles given on the command line: --rotate turns about the handle's rest centroid.
std::vector<io::Handle> handles_from_args(const std::vector<cli::HandleArg>& args, const Points& rest) {
  std::vector<io::Handle> handles;
  for (const cli::HandleArg& a : args) {
    io::Handle h;
    h.vertices = io::read_index_file(a.file);
    if (h.vertices.empty()) throw io::FileError(a.file + ": no vertex index in the handle file");
    h.translate = a.translate;
    if (a.rotate_axis >= 0) {
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
      for (int i : h.vertices) {
        if (i < 0 || i >= rest.rows())
          throw Error(ErrorCode::IndexOutOfRange,
                      a.file + ": vertex " + std::to_string(i) + " outside [0, " + std::to_string(rest.rows()) + ")");
        centroid += rest.row(i).transpose();
      }
      centroid /= static_cast<double>(h.vertices.size());
      const Eigen::Matrix3d r =
          Eigen::AngleAxisd(a.rotate_degrees * M_PI / 180.0, Eigen::Vector3d::Unit(a.rotate_axis)).toRotationMatrix();
      h.matrix.topLeftCorner<3, 3>() = r;
      h.matrix.topRightCorner<3, 1>() = centroid - r * centroid;
    }
    handles.push_back(std::move(h));
  }
  return handles;
}

// Fail before any work when a result could not be written.
void check_writable_folder(const std::string& file) {
  const std::filesystem::path folder = std::filesystem::path(file).parent_path();
  std::error_code ec;
  if (!folder.empty() && !std::filesystem::is_directory(folder, ec))
    throw io::FileError(file + ": the folder " + folder.string() + " does not exist");
}

int run(const cli::DeformArgs& args) {
  const auto start = Clock::now();
  check_writable_folder(args.output);
  if (!args.report.empty()) check_writable_folder(args.report);
  std::string mesh_path = args.input;
  std::vector<int> fixed;
  std::vector<io::Handle> handles;
  io::Scenario scenario;
  if (!args.scenario.empty()) {
    scenario = io::load_scenario(args.scenario);
    mesh_path = scenario.mesh_path;
  }
  const io::PolygonMesh mesh = io::read_mesh(mesh_path);
  if (!args.scenario.empty()) {
    fixed = scenario.fixed;
    handles = scenario.handles;
  } else {
    if (!args.fixed_file.empty()) fixed = io::read_index_file(args.fixed_file);
    handles = handles_from_args(args.handles, mesh.vertices);
  }
  const Triangles triangles = io::triangulate(mesh.polygons);
  const io::Constraints constraints = io::build_constraints(mesh.vertices, fixed, handles);
  const double read_ms = ms_since(start);

  Solver solver;
  const auto bind_start = Clock::now();
  solver.bind(mesh.vertices, triangles, constraints.constrained, args.options);
  const double precompute_ms = ms_since(bind_start);
  const double cpu_start = thread_cpu_ms();
  const SolveStats stats = solver.solve(constraints.targets);
  const double solve_cpu_ms = thread_cpu_ms() - cpu_start;

  cli::RunInfo info;
  info.mesh_path = mesh_path;
  info.vertices = static_cast<int>(mesh.vertices.rows());
  info.faces = static_cast<int>(mesh.polygons.size());
  info.triangles = static_cast<int>(triangles.rows());
  info.fixed = constraints.fixed_count;
  info.handle_vertices = static_cast<int>(constraints.constrained.size()) - constraints.fixed_count;
  info.read_ms = read_ms;
  info.precompute_ms = precompute_ms;
  info.total_ms = ms_since(start);
  info.solve_cpu_ms = solve_cpu_ms;
  info.distortion = rigidity_distortion(mesh.vertices, solver.positions(), triangles, &info.flipped_triangles);

  // Write both files under temporary names, then rename: all or nothing.
  const std::string mesh_tmp = temp_path_for(args.output);
  const std::string report_tmp = args.report.empty() ? "" : temp_path_for(args.report);
  try {
    io::write_mesh(mesh_tmp, solver.positions(), mesh.polygons);
    if (!report_tmp.empty()) {
      std::ofstream out(report_tmp);
      out << cli::make_report(info, solver, stats).dump(2) << '\n';
      out.close();
      if (!out) throw io::FileError(args.report + ": cannot write the report");
      std::filesystem::rename(report_tmp, args.report);
    }
    std::filesystem::rename(mesh_tmp, args.output);
  } catch (const std::filesystem::filesystem_error& e) {
    std::filesystem::remove(mesh_tmp);
    if (!report_tmp.empty()) std::filesystem::remove(report_tmp);
    throw io::FileError(args.output + ": cannot write the output (" + e.code().message() + ")");
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(mesh_tmp, ec);
    if (!report_tmp.empty()) std::filesystem::remove(report_tmp, ec);
    throw;
  }

  for (const std::string& w : constraints.warnings) std::cerr << "arap-deform: warning: " << w << '\n';
  const MeshReport& report = solver.mesh_report();
  if (solver.options().volume == Volume::Global && report.volume_open_components > 0)
    std::cerr << "arap-deform: warning: --volume global keeps the volume of " << report.volume_kept_components
              << " closed part(s); " << report.volume_open_components
              << " open part(s) are left as they are (--volume infill fills open parts too)\n";
  if (stats.contact_reached < 1) {
    const std::string group = group_label_of(constraints, stats.contact_stopped_vertex);
    std::cerr << "arap-deform: warning: " << (group.empty() ? std::string("the handles") : group)
              << " stopped at " << static_cast<int>(100 * stats.contact_reached)
              << "% of the way: going further would make the surface pass through itself (--contact self)\n";
  }
  if (!stats.converged && args.options.tolerance > 0)
    std::cerr << "arap-deform: stopped at the cap of " << stats.iterations
              << " iterations before the energy settled (tolerance " << args.options.tolerance
              << "); raise --max-iterations to go on\n";
  if (!args.quiet) {
    std::printf("%s: %d vertices, %d faces (%d triangles), %d fixed, %d handle vertices\n", mesh_path.c_str(),
                info.vertices, info.faces, info.triangles, info.fixed, info.handle_vertices);
    std::printf("method %s, weights %s, init %s, bind %.2f ms\n", to_string(solver.options().method).c_str(),
                to_string(solver.options().weights).c_str(), to_string(solver.options().init).c_str(),
                precompute_ms);
    std::printf("iter %4d  energy %.9g  (first guess, %.2f ms)\n", 0, stats.initial_energy, stats.init_ms);
    for (int k = 0; k < stats.iterations; ++k)
      std::printf("iter %4d  energy %.9g  (%.2f ms)\n", k + 1, stats.energy[k], stats.iteration_ms[k]);
    std::printf("%s after %d iterations; wrote %s\n",
                stats.converged ? "converged" : "stopped at the iteration cap", stats.iterations, args.output.c_str());
  }
  return 0;
}

// One line: the message without its newlines.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const cli::DeformArgs args = cli::parse_deform_args(argc, argv);
    if (args.help) {
      std::fputs(cli::deform_usage().c_str(), stdout);
      return 0;
    }
    return run(args);
  } catch (const cli::UsageError& e) {
    std::cerr << "arap-deform: " << one_line(e.what()) << " (see --help)\n";
    return 2;
  } catch (const Error& e) {
    std::cerr << "arap-deform: " << error_code_name(e.code()) << ": " << one_line(e.what()) << '\n';
    return 2;
  } catch (const io::FileError& e) {
    std::cerr << "arap-deform: " << one_line(e.what()) << '\n';
    return 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "arap-deform: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "arap-deform: internal error: " << one_line(e.what()) << '\n';
    return 1;
  }
}
