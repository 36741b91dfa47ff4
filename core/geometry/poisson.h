// Poisson and harmonic interpolation of per-vertex values on triangle meshes: the base of the surface
// texture inpainting of the paper's section 5 (solve  Delta f = d  in a region, f = f* on its border).
//
// Discretisation: linear finite elements. The stiffness matrix L (cotangentLaplacian) is symmetric
// positive semi-definite:  L_ij = -(cot a_ij + cot b_ij)/2 for an edge ij (a_ij, b_ij the angles
// opposite the edge), L_ii = -sum_j L_ij, so  f^T L f = integral |grad f|^2  and L 1 = 0. The mass
// matrix M is lumped (vertexAreas: one third of the incident face areas). With this sign convention
// the usual Laplacian is  Delta f ~= -M^-1 L f,  and "Delta f = d" is solved as  L f = -M d  (so on a
// flat plane f = x^2 + y^2 has Delta f = +4, as in calculus).
//
// Near-degenerate triangles: every cotangent is clamped to [-1e3, 1e3], so slivers give large but
// finite weights and never NaN/inf. (The alternative, not done here, is the intrinsic Delaunay
// Laplacian, which also keeps all weights non-negative.)
#pragma once

#include <Eigen/Core>
#include <Eigen/Sparse>
#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "geometry/mesh.h"

namespace montage {

// A triangle soup with shared vertices: the refined surface of inpainting and every mesh the
// Poisson solver takes (building an OpenMesh Mesh for a million refined vertices would cost seconds).
struct TriangleMesh {
  std::vector<Vec3> positions;
  std::vector<std::array<int, 3>> triangles;
  int numVertices() const { return static_cast<int>(positions.size()); }
  int numTriangles() const { return static_cast<int>(triangles.size()); }
};
TriangleMesh toTriangleMesh(const Mesh& mesh);

// Some triangles of a TriangleMesh with their vertices renumbered: `vertex[l]` is the vertex of the
// whole mesh that local vertex l stands for. `localOf` is scratch of #V entries, all -1 on entry and
// on return.
struct SubMesh {
  TriangleMesh mesh;
  std::vector<int> vertex;  // local -> vertex of the whole mesh
};
SubMesh extractTriangles(const TriangleMesh& mesh, const std::vector<int>& triangles, std::vector<int>& localOf);

// The #V x #V positive semi-definite cotangent stiffness matrix described above (cotangents clamped to
// [-1e3, 1e3]). Unreferenced vertices have empty rows.
Eigen::SparseMatrix<double> cotangentLaplacian(const TriangleMesh& mesh);
inline Eigen::SparseMatrix<double> cotangentLaplacian(const Mesh& mesh) {
  return cotangentLaplacian(toTriangleMesh(mesh));
}

// Lumped (barycentric) vertex areas: one third of the area of every incident face. #V entries.
Eigen::VectorXd vertexAreas(const TriangleMesh& mesh);
inline Eigen::VectorXd vertexAreas(const Mesh& mesh) {
  return vertexAreas(toTriangleMesh(mesh));
}

// Dirichlet Poisson solver for one region, factorised once and reused for many right-hand sides
// (colour channels, successive guidance edits).
//
// Backend, chosen by measurement (docs/pipeline.md, `tm_inpaint_bench`): Eigen's SimplicialLDLT up to
// kCholmodAbove unknowns, CHOLMOD's supernodal Cholesky (SuiteSparse, on OpenBLAS) above, where its
// dense kernels make the factorisation two to three times faster.
class PoissonSolver {
 public:
  enum class Backend { Auto, SimplicialLDLT, Cholmod };
  static constexpr int kCholmodAbove = 50000;

  // `isFixed` has #V entries; vertices with a non-zero entry keep their given value, the others are
  // unknowns. Vertices no face uses are always treated as fixed. Throws montage::Error when isFixed has
  // the wrong size, or when some connected component of unknowns touches no fixed vertex (the problem
  // would be singular); the message says how many vertices are affected.
  PoissonSolver(const TriangleMesh& mesh, const std::vector<char>& isFixed, Backend backend = Backend::Auto);
  PoissonSolver(const Mesh& mesh, const std::vector<char>& isFixed) : PoissonSolver(toTriangleMesh(mesh), isFixed) {}
  ~PoissonSolver();
  PoissonSolver(PoissonSolver&&) noexcept;

  // Solves  Delta f = d  on the unknowns (L f = -M d, see above) with f = fixedValues on fixed
  // vertices. `d` and `fixedValues` are #V x C (any number C of channels, same for both); rows of
  // unknowns in fixedValues and rows of fixed vertices in d are ignored. Returns #V x C: the fixed
  // rows copied from fixedValues, the unknown rows solved. Throws montage::Error on size mismatch.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& d, const Eigen::MatrixXd& fixedValues) const;

  int unknowns() const { return static_cast<int>(unknownVertex_.size()); }
  Backend backend() const;
  double factorSeconds() const { return factorSeconds_; }

 private:
  int numVertices_ = 0;
  std::vector<int> unknownVertex_;   // unknown index -> vertex
  std::vector<int> fixedVertex_;     // fixed index -> vertex
  Eigen::VectorXd unknownArea_;      // lumped mass of each unknown
  Eigen::SparseMatrix<double> kUF_;  // unknowns x fixed block of L
  struct Factor;                     // the factorisation of the unknowns x unknowns block
  std::unique_ptr<Factor> factor_;
  double factorSeconds_ = 0;
};

// Factorisations kept across runs, keyed by the exact mesh and fixed set they were made for: a hole
// whose refined surface and border did not change between two edits (only the colours around it
// did) is solved again without a new factorisation. Keeps what this run and the one before used (a
// preview and a final run in turn keep both). `solver` may be called from several threads at once.
class PoissonCache {
 public:
  // `factorised` (may be null): set to whether this call factorised (false: the solver was kept).
  std::shared_ptr<const PoissonSolver> solver(const TriangleMesh& mesh, const std::vector<char>& isFixed,
                                              bool* factorised = nullptr);
  void endRun();             // the run is over: solvers unused in this run and the one before are dropped
  int reused = 0, made = 0;  // this run (read them when no call is running)

 private:
  std::mutex mutex_;
  std::map<std::string, std::shared_ptr<const PoissonSolver>> current_, previous_;
};

// One-shot harmonic interpolation (d = 0): fills the unknown vertices of `fixedValues` (#V x C).
Eigen::MatrixXd harmonicFill(const TriangleMesh& mesh, const std::vector<char>& isFixed,
                             const Eigen::MatrixXd& fixedValues);
inline Eigen::MatrixXd harmonicFill(const Mesh& mesh, const std::vector<char>& isFixed,
                                    const Eigen::MatrixXd& fixedValues) {
  return harmonicFill(toTriangleMesh(mesh), isFixed, fixedValues);
}

}  // namespace montage
