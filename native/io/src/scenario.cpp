#include "arap/io/scenario.h"

#include <climits>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "arap/errors.h"
#include "arap/io/files.h"
#include "arap/io/numbers.h"

namespace arap::io {
namespace {

using nlohmann::json;

[[noreturn]] void invalid(const std::string& path, const std::string& what) {
  throw Error(ErrorCode::InvalidInput, path + ": " + what);
}

// A scenario nests 5 levels deep (object, handles, handle, matrix, row); a
// deeper document is refused while it is parsed, before anything recursive
// (dump(), the destructor) could run out of stack on it.
constexpr int kMaxDepth = 32;

// A JSON value for an error message: one line, at most 40 characters.
std::string shown(const json& j) {
  std::string s = j.dump();
  return s.size() > 40 ? s.substr(0, 37) + "..." : s;
}

std::vector<int> index_list(const std::string& path, const json& j, const std::string& where) {
  if (!j.is_array()) invalid(path, where + " must be a list of vertex indices");
  std::vector<int> out;
  out.reserve(j.size());
  for (const json& v : j) {
    if (!v.is_number_integer()) invalid(path, where + " holds " + shown(v) + ", not an integer vertex index");
    // Unsigned values above 2^63 must not wrap to negative numbers.
    if (v.is_number_unsigned() ? v.get<unsigned long long>() > INT_MAX
                               : v.get<long long>() < INT_MIN || v.get<long long>() > INT_MAX)
      throw Error(ErrorCode::IndexOutOfRange, path + ": " + where + " holds the index " + shown(v));
    out.push_back(static_cast<int>(v.get<long long>()));
  }
  return out;
}

double number(const std::string& path, const json& j, const std::string& where) {
  if (!j.is_number()) invalid(path, where + " holds " + shown(j) + ", not a number");
  return j.get<double>();
}

Eigen::Matrix4d read_matrix(const std::string& path, const json& j, const std::string& where) {
  // Accepted as 16 numbers (row-major) or as 4 rows of 4.
  std::vector<double> flat;
  if (j.is_array() && j.size() == 4 && j[0].is_array()) {
    for (const json& row : j) {
      if (!row.is_array() || row.size() != 4) invalid(path, where + " must be 4 rows of 4 numbers");
      for (const json& x : row) flat.push_back(number(path, x, where));
    }
  } else if (j.is_array() && j.size() == 16) {
    for (const json& x : j) flat.push_back(number(path, x, where));
  } else {
    invalid(path, where + " must be a 4x4 matrix (16 numbers, row-major)");
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = flat[4 * r + c];
  if (m(3, 0) != 0 || m(3, 1) != 0 || m(3, 2) != 0 || m(3, 3) != 1)
    invalid(path, where + " is not affine (its last row must be 0 0 0 1)");
  return m;
}

}  // namespace

Scenario load_scenario(const std::string& json_path) {
  require_regular_file(json_path, "scenario file");
  std::ifstream in(json_path);
  if (!in) throw FileError(json_path + ": cannot open the scenario file");
  json doc;
  bool too_deep = false;
  try {
    // The callback sees every value with its depth; returning false on the
    // first one too deep would keep parsing, so a flag and a throw stop it.
    doc = json::parse(in, [&too_deep](int depth, json::parse_event_t, json&) {
      if (depth > kMaxDepth) {
        too_deep = true;
        throw std::length_error("too deep");
      }
      return true;
    });
  } catch (const json::exception& e) {
    std::string why = e.what();  // quotes the offending token, which may be long
    if (why.size() > 200) why = why.substr(0, 197) + "...";
    throw FileError(json_path + ": not valid JSON (" + why + ")");
  } catch (const std::length_error&) {
    if (!too_deep) throw;
    throw FileError(json_path + ": JSON nested deeper than " + std::to_string(kMaxDepth) +
                    " levels (a scenario needs 5)");
  }
  if (!doc.is_object()) invalid(json_path, "the scenario must be a JSON object");
  Scenario s;
  if (doc.contains("name") && doc["name"].is_string()) s.name = doc["name"].get<std::string>();
  if (!doc.contains("mesh") || !doc["mesh"].is_string()) invalid(json_path, "\"mesh\" (a path) is missing");
  const std::filesystem::path mesh = doc["mesh"].get<std::string>();
  s.mesh_path = mesh.is_absolute() ? mesh.string() : (std::filesystem::path(json_path).parent_path() / mesh).string();
  if (doc.contains("fixed")) s.fixed = index_list(json_path, doc["fixed"], "\"fixed\"");
  if (doc.contains("handles")) {
    const json& hs = doc["handles"];
    if (!hs.is_array()) invalid(json_path, "\"handles\" must be a list");
    for (std::size_t k = 0; k < hs.size(); ++k) {
      const std::string where = "handle " + std::to_string(k);
      const json& h = hs[k];
      if (!h.is_object() || !h.contains("vertices")) invalid(json_path, where + " has no \"vertices\"");
      Handle handle;
      handle.vertices = index_list(json_path, h["vertices"], where + " \"vertices\"");
      if (h.contains("matrix")) handle.matrix = read_matrix(json_path, h["matrix"], where + " \"matrix\"");
      if (h.contains("translate")) {
        const json& t = h["translate"];
        if (!t.is_array() || t.size() != 3) invalid(json_path, where + " \"translate\" must be 3 numbers");
        for (int c = 0; c < 3; ++c) handle.translate[c] = number(json_path, t[c], where + " \"translate\"");
      }
      s.handles.push_back(std::move(handle));
    }
  }
  return s;
}

std::vector<int> read_index_file(const std::string& path) {
  require_regular_file(path, "index file");
  std::ifstream in(path);
  if (!in) throw FileError(path + ": cannot open the index file");
  std::vector<int> out;
  std::string token;
  while (in >> token) {
    long long v = -1;
    if (token[0] < '0' || token[0] > '9' || !parse_integer(token, v) || v > INT_MAX)
      throw FileError(path + ": '" + token.substr(0, 20) + "' is not a vertex index");
    out.push_back(static_cast<int>(v));
  }
  return out;
}

Constraints build_constraints(const Points& rest, const std::vector<int>& fixed, const std::vector<Handle>& handles) {
  std::vector<ConstraintGroup> groups;
  std::vector<Eigen::Matrix4d> transforms;
  for (std::size_t k = 0; k < handles.size(); ++k) {
    groups.push_back({"handle " + std::to_string(k), handles[k].vertices});
    Eigen::Matrix4d m = handles[k].matrix;
    m.topRightCorner<3, 1>() += handles[k].translate;
    transforms.push_back(m);
  }
  Constraints c;
  static_cast<ConstraintSet&>(c) =
      make_constraint_set(static_cast<int>(rest.rows()), {"the fixed list", fixed}, groups);
  c.targets = constraint_targets(c, rest, transforms);
  return c;
}

}  // namespace arap::io
