#include "mesh_prescan.h"

#include <cctype>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>
#include <vector>

#include "arap/io/files.h"
#include "arap/io/numbers.h"

namespace arap::io::detail {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw FileError(path + ": " + what); }

// Whitespace tokens of a text, with line awareness. With `comments`, '#'
// starts a comment that runs to the end of its line (OFF allows them).
class Cursor {
 public:
  explicit Cursor(std::string_view text, bool comments = false) : text_(text), comments_(comments) {}
  bool at_end() const { return pos_ >= text_.size(); }
  std::string_view next() {
    for (;;) {
      while (pos_ < text_.size() && is_space(text_[pos_])) ++pos_;
      if (!comments_ || pos_ >= text_.size() || text_[pos_] != '#') break;
      while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    }
    size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_]) && !(comments_ && text_[pos_] == '#')) ++pos_;
    return text_.substr(start, pos_ - start);
  }
  std::string_view line() {
    size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    std::string_view l = text_.substr(start, pos_ - start);
    if (pos_ < text_.size()) ++pos_;
    return l;
  }
  // The first token of the rest of the current line (empty when there is none).
  std::string_view rest_of_line() { return Cursor(line(), comments_).next(); }
  void skip_line() { line(); }
  size_t remaining() const { return text_.size() - pos_; }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
  std::string_view text_;
  bool comments_;
  size_t pos_ = 0;
};

// Non-negative decimal integer of at most 18 digits (no sign), or -1.
long long parse_count(std::string_view t) {
  long long v = -1;
  if (t.empty() || t.size() > 18 || t[0] < '0' || t[0] > '9' || !io::parse_integer(t, v)) return -1;
  return v;
}

bool parse_finite(std::string_view t, double& out) { return t.size() <= 64 && io::parse_finite(t, out); }

// OpenMesh's OBJ, PLY and STL readers parse coordinates as float: a value
// beyond the float range fails its stream (the rest of the file is then
// misread) or is clamped to 3.4e38. Such files are refused with this reason.
constexpr const char* kBeyondFloat = " is beyond single precision (|x| > 3.4e38), which this format's reader uses";

bool fits_float(double x) { return std::abs(x) <= static_cast<double>(std::numeric_limits<float>::max()); }

// A decimal integer (optional '-' when `is_signed`) within [lo, hi].
bool parse_integer(std::string_view t, long long lo, long long hi) {
  const bool negative = !t.empty() && t[0] == '-';
  if (negative) t.remove_prefix(1);
  const long long v = parse_count(t);
  if (v < 0) return false;
  return negative ? -v >= lo : v <= hi;
}

std::string shown(std::string_view t) {
  std::string s(t.substr(0, 20));
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
  return "'" + s + "'";
}

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// OFF, read here in full (OpenMesh's OFF reader knows no comments and parses
// floats). Header keyword [ST][C][N]OFF, then "#vertices #faces #edges" (on
// the keyword's line or the next), one vertex per line (x y z, then anything:
// normals, colours, texture coordinates), one face per line ("k i1 .. ik").
// '#' starts a comment anywhere.
Expected scan_off(const std::string& path, const std::string& data) {
  Cursor c(data, true);
  std::string_view magic = c.next();
  if (magic.size() < 3 || magic.substr(magic.size() - 3) != "OFF") fail(path, "not an OFF file (no OFF header line)");
  if (magic.find('4') != std::string_view::npos || magic.find('n') != std::string_view::npos)
    fail(path, "4D/nD OFF variants are not supported");
  std::string_view first = c.next();
  if (first == "BINARY") fail(path, "binary OFF is not supported");
  const long long nv = parse_count(first), nf = parse_count(c.next()), ne = parse_count(c.next());
  if (nv < 0 || nf < 0 || ne < 0) fail(path, "malformed OFF counts line (expected '#vertices #faces #edges')");
  // Smallest possible records: "0 0 0\n" and "3 0 0 0\n" (divided first: 18-digit counts would overflow).
  const long long size = static_cast<long long>(data.size());
  if (nv > size / 5 || nf > size / 7 || nv * 5 + nf * 7 > size)
    fail(path, "OFF header claims " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                   " faces, more than a " + std::to_string(data.size()) + "-byte file can hold");
  c.skip_line();
  Expected out{nv, nf, {}, true, {}};
  out.coordinates.reserve(3 * static_cast<size_t>(nv));
  for (long long i = 0; i < nv; ++i) {
    for (int k = 0; k < 3; ++k) {
      std::string_view t = c.next();
      double x;
      if (t.empty()) fail(path, "truncated: the file ends in vertex " + std::to_string(i));
      if (!parse_finite(t, x))
        fail(path, "vertex " + std::to_string(i) + ": coordinate " + shown(t) + " is not a finite number");
      out.coordinates.push_back(x);
    }
    c.skip_line();  // normals, colours, texture coordinates
  }
  out.polygons.reserve(static_cast<size_t>(nf));
  for (long long f = 0; f < nf; ++f) {
    std::string_view t = c.next();
    if (t.empty()) fail(path, "truncated: the file ends before face " + std::to_string(f));
    const long long k = parse_count(t);
    if (k < 3 || k > static_cast<long long>(c.remaining()))
      fail(path, "face " + std::to_string(f) + ": bad vertex count " + shown(t));
    std::vector<int>& face = out.polygons.emplace_back();
    face.reserve(static_cast<size_t>(k));
    for (long long j = 0; j < k; ++j) {
      std::string_view ti = c.next();
      if (ti.empty()) fail(path, "truncated: the file ends in face " + std::to_string(f));
      const long long idx = parse_count(ti);
      if (idx < 0 || idx >= nv)
        fail(path,
             "face " + std::to_string(f) + ": vertex index " + shown(ti) + " outside [0, " + std::to_string(nv) + ")");
      face.push_back(static_cast<int>(idx));
    }
    // A per-face colour would make a wrong face count indistinguishable from a colour.
    if (!c.rest_of_line().empty())
      fail(path, "face " + std::to_string(f) + ": values after the vertex indices (face colours are not supported)");
  }
  return out;
}

// PLY: header, then a walk over every element so that no count is trusted.
struct PlyType {
  int size = 0;  // bytes; 0 for an unknown type name
  bool is_float = false;
  bool is_signed = false;
};
struct PlyProperty {
  PlyType item;           // the scalar, or the list items
  PlyType count;          // the list count; size 0 for scalars
  bool coordinate = false;  // x, y or z of a vertex
};
struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> properties;
};

PlyType ply_type(std::string_view t) {
  if (t == "char" || t == "int8") return {1, false, true};
  if (t == "uchar" || t == "uint8") return {1, false, false};
  if (t == "short" || t == "int16") return {2, false, true};
  if (t == "ushort" || t == "uint16") return {2, false, false};
  if (t == "int" || t == "int32") return {4, false, true};
  if (t == "uint" || t == "uint32") return {4, false, false};
  if (t == "float" || t == "float32") return {4, true, true};
  if (t == "double" || t == "float64") return {8, true, true};
  return {};
}

// An ASCII PLY value as OpenMesh will parse it: integers within their type,
// floats finite and within the float range (OpenMesh reads doubles as floats too).
bool valid_ascii_value(std::string_view t, const PlyType& type) {
  if (type.is_float) {
    double x;
    return parse_finite(t, x) && fits_float(x);
  }
  const long long bits = 8LL * type.size;
  const long long hi = type.is_signed ? (1LL << (bits - 1)) - 1 : (1LL << bits) - 1;
  const long long lo = type.is_signed ? -(1LL << (bits - 1)) : 0;
  return parse_integer(t, lo, hi);
}

long long read_binary_count(const unsigned char* p, int size, bool is_signed, bool big_endian) {
  unsigned long long v = 0;
  for (int i = 0; i < size; ++i)
    v |= static_cast<unsigned long long>(p[big_endian ? i : size - 1 - i]) << (8 * (size - 1 - i));
  if (is_signed && size < 8 && (v >> (8 * size - 1))) return -1;
  return static_cast<long long>(v);
}

double read_binary_float(const unsigned char* p, int size, bool big_endian) {
  unsigned char b[8];
  for (int i = 0; i < size; ++i) b[i] = p[big_endian ? size - 1 - i : i];  // host is little-endian
  if (size == 4) {
    float f;
    std::memcpy(&f, b, 4);
    return f;
  }
  double d;
  std::memcpy(&d, b, 8);
  return d;
}

Expected scan_ply(const std::string& path, const std::string& data) {
  Cursor c(data);
  // The header is checked strictly: OpenMesh's PLY header parser loops
  // forever once a numeric field (version, element count) fails to parse.
  auto trimmed = [](std::string_view l) { return l.substr(0, l.find_last_not_of(" \t\r") + 1); };
  if (trimmed(c.line()) != "ply") fail(path, "not a PLY file (no 'ply' magic line)");
  std::string format;
  std::vector<PlyElement> elements;
  bool ended = false;
  for (int line_no = 2; !c.at_end() && !ended; ++line_no) {
    std::string_view text = c.line();
    Cursor l(text);
    std::vector<std::string_view> tok;
    for (std::string_view t = l.next(); !t.empty(); t = l.next()) tok.push_back(t);
    const std::string bad = "malformed PLY header line " + std::to_string(line_no) + " " + shown(text);
    if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") continue;
    double version;
    if (tok[0] == "format") {
      if (tok.size() != 3 || !parse_finite(tok[2], version)) fail(path, bad);
      // 1.0 is the only PLY version; OpenMesh parses it as a float and loops forever on 1e40.
      if (version != 1.0) fail(path, "PLY version " + shown(tok[2]) + " is not supported (only 1.0 exists)");
      format = std::string(tok[1]);
    } else if (tok[0] == "element") {
      if (tok.size() != 3) fail(path, bad);
      PlyElement e;
      e.name = std::string(tok[1]);
      e.count = parse_count(tok[2]);
      if (e.count < 0 || e.count > 0xffffffffLL) fail(path, bad);
      elements.push_back(e);
    } else if (tok[0] == "property") {
      if (elements.empty()) fail(path, "PLY property before any element");
      PlyProperty p;
      const bool list = tok.size() == 5 && tok[1] == "list";
      if (!list && tok.size() != 3) fail(path, bad);
      if (list) {
        p.count = ply_type(tok[2]);
        if (p.count.size == 0 || p.count.is_float) fail(path, bad);
      }
      p.item = ply_type(tok[list ? 3 : 1]);
      if (p.item.size == 0) fail(path, bad);
      const std::string_view name = tok.back();
      p.coordinate = elements.back().name == "vertex" && (name == "x" || name == "y" || name == "z");
      elements.back().properties.push_back(p);
    } else if (tok[0] == "end_header" && tok.size() == 1) {
      ended = true;
    } else {
      fail(path, bad);
    }
  }
  if (!ended) fail(path, "PLY header has no end_header");
  const bool ascii = format == "ascii";
  const bool big = format == "binary_big_endian";
  if (!ascii && !big && format != "binary_little_endian") fail(path, "unknown PLY format " + shown(format));
  Expected expected;
  const long long body = static_cast<long long>(c.remaining());
  long long claimed = 0;
  for (const PlyElement& e : elements) {
    if (e.properties.empty() && e.count > 0) fail(path, "PLY element '" + e.name + "' has no properties");
    claimed += e.count;
    if (claimed > body)
      fail(path, "PLY header claims more elements than a " + std::to_string(data.size()) + "-byte file can hold");
    if (e.name == "vertex") expected.vertices = e.count;
    if (e.name == "face") expected.faces = e.count;
  }
  const size_t start = data.size() - c.remaining();
  if (ascii) {
    for (const PlyElement& e : elements) {
      for (long long i = 0; i < e.count; ++i) {
        for (const PlyProperty& p : e.properties) {
          long long n = 1;
          if (p.count.size) {
            std::string_view t = c.next();
            n = parse_count(t);
            if (n < 0 || n > static_cast<long long>(c.remaining()) || !valid_ascii_value(t, p.count))
              fail(path, e.name + " " + std::to_string(i) + ": bad list length " + shown(t));
          }
          for (long long j = 0; j < n; ++j) {
            std::string_view t = c.next();
            if (t.empty()) fail(path, "truncated: the file ends in " + e.name + " " + std::to_string(i));
            double x;
            if (p.coordinate && !parse_finite(t, x))
              fail(path, "vertex " + std::to_string(i) + ": coordinate " + shown(t) + " is not a finite number");
            if (p.coordinate && !fits_float(x))
              fail(path, "vertex " + std::to_string(i) + ": coordinate " + shown(t) + kBeyondFloat);
            if (!valid_ascii_value(t, p.item))
              fail(path, e.name + " " + std::to_string(i) + ": " + shown(t) + " is not a valid " +
                             (p.item.is_float ? "float (finite, |x| <= 3.4e38)" : "integer of its type"));
            if (p.coordinate) expected.coordinates.push_back(x);
          }
        }
      }
    }
    return expected;
  }
  size_t pos = start;
  const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
  for (const PlyElement& e : elements) {
    for (long long i = 0; i < e.count; ++i) {
      for (const PlyProperty& p : e.properties) {
        long long n = 1;
        if (p.count.size) {
          if (pos + p.count.size > data.size())
            fail(path, "truncated: the file ends in " + e.name + " " + std::to_string(i));
          n = read_binary_count(bytes + pos, p.count.size, p.count.is_signed, big);
          pos += p.count.size;
          if (n < 0 || n > static_cast<long long>(data.size() - pos) / p.item.size)
            fail(path, e.name + " " + std::to_string(i) + ": bad list length " + std::to_string(n));
        }
        if (pos + n * p.item.size > data.size())
          fail(path, "truncated: the file ends in " + e.name + " " + std::to_string(i));
        if (p.coordinate && p.item.is_float) {
          const double x = read_binary_float(bytes + pos, p.item.size, big);
          if (!std::isfinite(x))
            fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
          if (!fits_float(x))
            fail(path, "vertex " + std::to_string(i) + ": coordinate " + std::to_string(x) + kBeyondFloat);
        }
        pos += n * p.item.size;
      }
    }
  }
  return expected;
}

// OpenMesh's OBJ reader opens the material library named by `mtllib`
// (relative to the OBJ's folder) and reads it to the end: a name such as
// ../../dev/urandom or a FIFO would hang it. Only regular files (or missing
// ones, which OpenMesh skips) are allowed.
void check_material_library(const std::string& path, std::string name) {
  namespace fs = std::filesystem;
  while (!name.empty() && std::isspace(static_cast<unsigned char>(name.front()))) name.erase(0, 1);
  while (!name.empty() && std::isspace(static_cast<unsigned char>(name.back()))) name.pop_back();
  if (name.empty()) return;
  for (const fs::path& candidate : {fs::path(path).parent_path() / name, fs::path(name)}) {
    std::error_code ec;
    const fs::file_status st = fs::status(candidate, ec);
    if (!ec && fs::exists(st) && !fs::is_regular_file(st))
      fail(path, "mtllib " + shown(name) + " is not a regular file");
  }
}

// One vertex of an OBJ face: v, v/vt, v//vn or v/vt/vn, v a non-zero
// integer (negative counts back from the last vertex). OpenMesh 9.0's OBJ
// reader aborts on an assertion when a face token starts with '/'.
bool valid_obj_face_vertex(std::string_view t) {
  // Up to three '/'-separated fields; the first required and non-zero, the others integers or empty.
  for (int field = 0; field < 3; ++field) {
    const size_t slash = t.find('/');
    const std::string_view part = t.substr(0, slash);
    const bool required = field == 0;
    if (required && (part.empty() || part == "0" || part == "-0")) return false;
    if (!part.empty() && !parse_integer(part, INT_MIN + 1LL, INT_MAX)) return false;
    if (slash == std::string_view::npos) return true;
    t.remove_prefix(slash + 1);
  }
  return false;  // a fourth field
}

// Whether OpenMesh 9.0's OBJ reader ignores this token of a face line. It has
// no comments there: it reads an integer from each token ('/'-separated
// fields), skips a token without '/' whose integer does not parse, and takes
// a field that does not parse as 0. So "# see 4" adds vertex 4, "#/1" adds
// vertex 0 (index -1), and "#1 /1" still aborts on the '/1'.
bool openmesh_skips_face_token(std::string_view t) {
  if (t.find('/') != std::string_view::npos) return false;
  const size_t digit = t[0] == '+' || t[0] == '-' ? 1 : 0;
  return digit >= t.size() || t[digit] < '0' || t[digit] > '9';
}

Expected scan_obj(const std::string& path, const std::string& data) {
  Cursor c(data);
  Expected expected{0, 0, {}, false, {}};
  for (long long line_no = 1; !c.at_end(); ++line_no) {
    Cursor l(c.line());
    std::string_view key = l.next();
    if (key == "v") {
      for (int k = 0; k < 3; ++k) {
        std::string_view t = l.next();
        double x;
        if (!parse_finite(t, x))
          fail(path, "line " + std::to_string(line_no) + ": vertex coordinate " + shown(t) + " is not a finite number");
        if (!fits_float(x))
          fail(path, "line " + std::to_string(line_no) + ": vertex coordinate " + shown(t) + kBeyondFloat);
        expected.coordinates.push_back(x);
      }
      ++expected.vertices;
    } else if (key == "f") {
      // OpenMesh reads every token of a face line, comments included (see
      // openmesh_skips_face_token): a comment may only hold tokens it skips.
      bool comment = false;
      for (std::string_view t = l.next(); !t.empty(); t = l.next()) {
        comment = comment || t[0] == '#';
        if (comment && !openmesh_skips_face_token(t))
          fail(path, "line " + std::to_string(line_no) + ": the comment in this face line has " + shown(t) +
                         ", which OpenMesh would read as a vertex: move the comment to a line of its own");
        if (!comment && !valid_obj_face_vertex(t))
          fail(path, "line " + std::to_string(line_no) + ": face vertex " + shown(t) +
                         " is not v, v/vt, v//vn or v/vt/vn with integer indices");
      }
      ++expected.faces;
    } else if (key == "mtllib") {
      check_material_library(path, std::string(l.line()));
    }
  }
  return expected;
}

Expected scan_stl(const std::string& path, const std::string& data) {
  if (data.size() >= 84) {
    unsigned long long n = 0;
    for (int i = 0; i < 4; ++i)
      n |= static_cast<unsigned long long>(static_cast<unsigned char>(data[80 + i])) << (8 * i);
    if (84 + 50 * n == data.size()) return {-1, static_cast<long long>(n), {}, false, {}};  // binary
  }
  Cursor c(data);
  if (c.next() != "solid")
    fail(path, "neither a binary STL (its size does not match its triangle count) nor an ASCII STL ('solid')");
  if (data.find("endsolid") == std::string::npos) fail(path, "truncated ASCII STL (no 'endsolid')");
  Expected expected{-1, 0, {}, false, {}};
  for (std::string_view t = c.next(); !t.empty(); t = c.next()) {
    expected.faces += t == "endfacet";
    if (t != "vertex") continue;
    for (int k = 0; k < 3; ++k) {
      std::string_view v = c.next();
      double x;
      const std::string where = "facet " + std::to_string(expected.faces) + ": coordinate " + shown(v);
      if (!parse_finite(v, x)) fail(path, where + " is not a finite number");
      if (!fits_float(x)) fail(path, where + kBeyondFloat);
    }
  }
  return expected;
}

}  // namespace

Expected prescan(const std::string& path, const std::string& ext) {
  const std::string data = read_all(path);
  if (ext == "off") return scan_off(path, data);
  if (ext == "ply") return scan_ply(path, data);
  if (ext == "obj") return scan_obj(path, data);
  if (ext == "stl") return scan_stl(path, data);
  fail(path, "unsupported format '." + ext + "' (expected .off, .obj, .ply or .stl)");
}

}  // namespace arap::io::detail
