// An OpenMesh importer that only records what a reader delivers: vertex
// positions and the index list of every face. No halfedge structure is built,
// so nothing is dropped for being non-manifold; validation happens afterwards.
#pragma once

#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace arap::io::detail {

// Thrown from inside a reader when it delivers more than the file can hold
// (second line of defence after the prescan); caught by read_mesh().
struct ImportLimitExceeded : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class RawImporter : public OpenMesh::IO::BaseImporter {
 public:
  // At most `max_elements` vertices and faces and 4x that many face indices.
  explicit RawImporter(std::size_t max_elements) : max_elements_(max_elements) {}

  std::vector<OpenMesh::Vec3d> points;
  std::vector<std::vector<int>> faces;

  using VertexHandle = OpenMesh::VertexHandle;
  using FaceHandle = OpenMesh::FaceHandle;
  using HalfedgeHandle = OpenMesh::HalfedgeHandle;
  using EdgeHandle = OpenMesh::EdgeHandle;
  using Status = OpenMesh::Attributes::StatusInfo;

  VertexHandle add_vertex(const OpenMesh::Vec3f& p) override;
  VertexHandle add_vertex(const OpenMesh::Vec3d& p) override;
  VertexHandle add_vertex() override { return add_vertex(OpenMesh::Vec3d(0, 0, 0)); }
  void set_point(VertexHandle vh, const OpenMesh::Vec3f& p) override;
  FaceHandle add_face(const VHandles& indices) override;
  // Only used by the OM format's reader, which read_mesh() never selects.
  FaceHandle add_face(HalfedgeHandle) override { throw ImportLimitExceeded("unsupported face construction"); }
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }

  std::size_t n_vertices() const override { return points.size(); }
  std::size_t n_faces() const override { return faces.size(); }
  std::size_t n_edges() const override { return 0; }

  // Attributes are ignored.
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_normal(VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(VertexHandle, const OpenMesh::Vec3d&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec4f&) override {}
  void set_texcoord(VertexHandle, const OpenMesh::Vec2f&) override {}
  void set_status(VertexHandle, const Status&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec3f&) override {}
  void set_status(HalfedgeHandle, const Status&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3f&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4f&) override {}
  void set_status(EdgeHandle, const Status&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3d&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4f&) override {}
  void set_status(FaceHandle, const Status&) override {}
  void add_texture_information(int, std::string) override {}

 private:
  std::size_t max_elements_;
  std::size_t total_indices_ = 0;
};

}  // namespace arap::io::detail
