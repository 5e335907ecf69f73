// Micro-benchmark of Self Contact's list of near pairs (docs/contact.md): the
// CPU time of the barrier at a posed shape, which makes a new list there each
// time (the calls alternate with the rest shape); the list is most of it.
//   build/arap-bench-contact-list REST.obj POSED.obj [lists] [threads]
// POSED: the same mesh deformed (an arap-deform output with --contact self).
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "arap/io/mesh_io.h"
#include "arap/io/polygons.h"
#include "contact/self_contact.h"
#include "cpu_clock.h"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s REST.obj POSED.obj [lists] [threads]\n", argv[0]);
    return 2;
  }
  const arap::io::PolygonMesh rest = arap::io::read_mesh(argv[1]);
  const arap::io::PolygonMesh posed = arap::io::read_mesh(argv[2]);
  if (posed.vertices.rows() != rest.vertices.rows()) {
    std::fprintf(stderr, "the two meshes have different vertex counts\n");
    return 2;
  }
  const int lists = argc > 3 ? std::stoi(argv[3]) : 40;
  const int threads = argc > 4 ? std::stoi(argv[4]) : 1;
  arap::contact::SelfContact contact;
  contact.bind(rest.vertices, arap::io::triangulate(rest.polygons), 1.0);
  contact.set_threads(threads);
  std::vector<double> ms;
  for (int k = 0; k < lists; ++k) {
    contact.energy(rest.vertices.data());
    const double t = threads > 1 ? bench::wall_ms() : bench::thread_cpu_ms();
    contact.energy(posed.vertices.data());
    ms.push_back((threads > 1 ? bench::wall_ms() : bench::thread_cpu_ms()) - t);
  }
  std::sort(ms.begin(), ms.end());
  std::printf(
      "near-pair list and barrier at the posed shape: median %.2f ms %s over %d lists (%ld made, %ld pairs active)\n",
      ms[ms.size() / 2], threads > 1 ? "wall (threads)" : "CPU", lists, contact.lists_made(), contact.active_pairs());
  return 0;
}
