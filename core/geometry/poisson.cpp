#include "geometry/poisson.h"

#include <Eigen/CholmodSupport>
#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "base/util.h"

namespace montage {

namespace {

constexpr double kMaxCot = 1e3;

// Cotangent of the angle between u and v, clamped to [-kMaxCot, kMaxCot]; finite for degenerate input.
double clampedCot(const Vec3& u, const Vec3& v) {
  const double dot = u.dot(v);
  const double cr = u.cross(v).norm();
  double c;
  if (cr > 0 && std::isfinite(cr))
    c = dot / cr;
  else
    c = dot > 0 ? kMaxCot : (dot < 0 ? -kMaxCot : 0.0);
  if (!std::isfinite(c)) c = dot >= 0 ? kMaxCot : -kMaxCot;
  return std::clamp(c, -kMaxCot, kMaxCot);
}

}  // namespace

struct PoissonSolver::Factor {
  using Matrix = Eigen::SparseMatrix<double>;
  Eigen::SimplicialLDLT<Matrix> ldlt;
  std::unique_ptr<Eigen::CholmodSupernodalLLT<Matrix>> cholmod;  // when chosen
  bool ok() const { return (cholmod ? cholmod->info() : ldlt.info()) == Eigen::Success; }
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs) const {
    if (cholmod) return cholmod->solve(rhs);
    return ldlt.solve(rhs);
  }
};

PoissonSolver::~PoissonSolver() = default;
PoissonSolver::PoissonSolver(PoissonSolver&&) noexcept = default;

PoissonSolver::Backend PoissonSolver::backend() const {
  return factor_ && factor_->cholmod ? Backend::Cholmod : Backend::SimplicialLDLT;
}

TriangleMesh toTriangleMesh(const Mesh& mesh) {
  TriangleMesh out;
  out.positions.resize(mesh.numVertices());
  for (int v = 0; v < mesh.numVertices(); ++v) out.positions[v] = mesh.position(v);
  out.triangles.resize(mesh.numFaces());
  for (int f = 0; f < mesh.numFaces(); ++f) out.triangles[f] = mesh.faceVertices(f);
  return out;
}

Eigen::SparseMatrix<double> cotangentLaplacian(const TriangleMesh& mesh) {
  const int nv = mesh.numVertices(), nf = mesh.numTriangles();
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(size_t(nf) * 12);
  for (int f = 0; f < nf; ++f) {
    const auto& fv = mesh.triangles[f];
    const std::array<Vec3, 3> p = {mesh.positions[fv[0]], mesh.positions[fv[1]], mesh.positions[fv[2]]};
    for (int k = 0; k < 3; ++k) {
      // Corner k is opposite the edge (k+1, k+2).
      const int i = fv[(k + 1) % 3], j = fv[(k + 2) % 3];
      const double w = 0.5 * clampedCot(p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
      t.emplace_back(i, j, -w);
      t.emplace_back(j, i, -w);
      t.emplace_back(i, i, w);
      t.emplace_back(j, j, w);
    }
  }
  Eigen::SparseMatrix<double> L(nv, nv);
  L.setFromTriplets(t.begin(), t.end());
  return L;
}

Eigen::VectorXd vertexAreas(const TriangleMesh& mesh) {
  Eigen::VectorXd a = Eigen::VectorXd::Zero(mesh.numVertices());
  for (const auto& t : mesh.triangles) {
    const Vec3& p0 = mesh.positions[t[0]];
    const double third = (mesh.positions[t[1]] - p0).cross(mesh.positions[t[2]] - p0).norm() / 6.0;
    for (int v : t) a[v] += third;
  }
  return a;
}

PoissonSolver::PoissonSolver(const TriangleMesh& mesh, const std::vector<char>& isFixed, Backend backend)
    : factor_(std::make_unique<Factor>()) {
  const auto start = std::chrono::steady_clock::now();
  numVertices_ = mesh.numVertices();
  const int nv = numVertices_;
  TM_CHECK(static_cast<int>(isFixed.size()) == nv, "PoissonSolver: isFixed has " + std::to_string(isFixed.size()) +
                                                       " entries, the mesh has " + std::to_string(nv) + " vertices");

  // Components of unknowns, from the faces (not from the weights, which may be zero on right angles),
  // by union-find: a million-vertex hole has no time for per-vertex adjacency lists.
  std::vector<char> used(nv, 0);
  for (const auto& fv : mesh.triangles)
    for (int v : fv) used[v] = 1;
  std::vector<char> fixed(nv);
  for (int v = 0; v < nv; ++v) fixed[v] = isFixed[v] != 0 || !used[v];
  UnionFind sets(nv);
  auto find = [&](int x) { return sets.find(x); };
  for (const auto& fv : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = fv[k], b = fv[(k + 1) % 3];
      if (!fixed[a] && !fixed[b]) sets.unite(a, b);
    }
  // Every component of unknowns must touch a fixed vertex.
  std::vector<char> anchored(nv, 0);
  for (const auto& fv : mesh.triangles)
    if (fixed[fv[0]] || fixed[fv[1]] || fixed[fv[2]])
      for (int v : fv)
        if (!fixed[v]) anchored[find(v)] = 1;
  int badVertices = 0, badComponents = 0;
  for (int v = 0; v < nv; ++v) {
    if (fixed[v] || anchored[find(v)]) continue;
    ++badVertices;
    if (find(v) == v) ++badComponents;
  }
  TM_CHECK(badComponents == 0, "PoissonSolver: " + std::to_string(badVertices) + " unknown vertices (in " +
                                   std::to_string(badComponents) +
                                   " connected component(s)) have no fixed vertex to anchor them; the "
                                   "problem would be singular. Fix at least one vertex in each region.");

  std::vector<int> index(nv);
  for (int v = 0; v < nv; ++v) {
    if (fixed[v]) {
      index[v] = static_cast<int>(fixedVertex_.size());
      fixedVertex_.push_back(v);
    } else {
      index[v] = static_cast<int>(unknownVertex_.size());
      unknownVertex_.push_back(v);
    }
  }
  const int nu = unknowns(), nb = static_cast<int>(fixedVertex_.size());

  const Eigen::SparseMatrix<double> L = cotangentLaplacian(mesh);
  const Eigen::VectorXd area = vertexAreas(mesh);
  unknownArea_.resize(nu);
  for (int u = 0; u < nu; ++u) unknownArea_[u] = area[unknownVertex_[u]];

  std::vector<Eigen::Triplet<double>> tuu, tub;
  tuu.reserve(L.nonZeros());
  for (int col = 0; col < L.outerSize(); ++col) {
    if (fixed[col]) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(L, col); it; ++it)
        if (!fixed[it.row()]) tub.emplace_back(index[it.row()], index[col], it.value());
    } else {
      for (Eigen::SparseMatrix<double>::InnerIterator it(L, col); it; ++it)
        if (!fixed[it.row()] && it.row() >= col) tuu.emplace_back(index[it.row()], index[col], it.value());
    }
  }
  kUF_.resize(nu, nb);
  kUF_.setFromTriplets(tub.begin(), tub.end());
  if (nu > 0) {
    Eigen::SparseMatrix<double> kUU(nu, nu);  // lower triangle only
    kUU.setFromTriplets(tuu.begin(), tuu.end());
    if (backend == Backend::Cholmod || (backend == Backend::Auto && nu > kCholmodAbove)) {
      factor_->cholmod = std::make_unique<Eigen::CholmodSupernodalLLT<Factor::Matrix>>();
      // AMD only: CHOLMOD's default also tries METIS and keeps the better, which costs more time than
      // it saves on these planar-like graphs (629k unknowns: 9.8 s default, 6.2 s AMD, 9.1 s METIS).
      factor_->cholmod->cholmod().nmethods = 1;
      factor_->cholmod->cholmod().method[0].ordering = CHOLMOD_AMD;
      factor_->cholmod->compute(kUU);
    } else {
      factor_->ldlt.compute(kUU);
    }
    TM_CHECK(factor_->ok(), "PoissonSolver: factorisation of the " + std::to_string(nu) + "-unknown system failed");
  }
  factorSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Eigen::MatrixXd PoissonSolver::solve(const Eigen::MatrixXd& d, const Eigen::MatrixXd& fixedValues) const {
  TM_CHECK(fixedValues.rows() == numVertices_, "PoissonSolver::solve: fixedValues has " +
                                                   std::to_string(fixedValues.rows()) + " rows, expected " +
                                                   std::to_string(numVertices_));
  TM_CHECK(d.rows() == numVertices_ && d.cols() == fixedValues.cols(),
           "PoissonSolver::solve: d is " + std::to_string(d.rows()) + " x " + std::to_string(d.cols()) + ", expected " +
               std::to_string(numVertices_) + " x " + std::to_string(fixedValues.cols()));
  const int nu = unknowns(), nb = static_cast<int>(fixedVertex_.size());
  const Eigen::Index C = fixedValues.cols();
  Eigen::MatrixXd out = fixedValues;
  if (nu == 0) return out;
  Eigen::MatrixXd fb(nb, C);
  for (int b = 0; b < nb; ++b) fb.row(b) = fixedValues.row(fixedVertex_[b]);
  // K_UU f_U = -M_U d_U - K_UF f_F
  Eigen::MatrixXd rhs(nu, C);
  for (int u = 0; u < nu; ++u) rhs.row(u) = -unknownArea_[u] * d.row(unknownVertex_[u]);
  rhs -= kUF_ * fb;
  const Eigen::MatrixXd x = factor_->solve(rhs);
  TM_CHECK(factor_->ok() && x.allFinite(), "PoissonSolver::solve: back substitution failed");
  for (int u = 0; u < nu; ++u) out.row(unknownVertex_[u]) = x.row(u);
  return out;
}

Eigen::MatrixXd harmonicFill(const TriangleMesh& mesh, const std::vector<char>& isFixed,
                             const Eigen::MatrixXd& fixedValues) {
  const PoissonSolver solver(mesh, isFixed);
  return solver.solve(Eigen::MatrixXd::Zero(fixedValues.rows(), fixedValues.cols()), fixedValues);
}

SubMesh extractTriangles(const TriangleMesh& m, const std::vector<int>& triangles, std::vector<int>& localOf) {
  SubMesh s;
  for (int t : triangles) {
    std::array<int, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      int& l = localOf[m.triangles[t][k]];
      if (l < 0) {
        l = static_cast<int>(s.vertex.size());
        s.vertex.push_back(m.triangles[t][k]);
        s.mesh.positions.push_back(m.positions[m.triangles[t][k]]);
      }
      tri[k] = l;
    }
    s.mesh.triangles.push_back(tri);
  }
  for (int v : s.vertex) localOf[v] = -1;  // leave the scratch array clean for the next call
  return s;
}

std::shared_ptr<const PoissonSolver> PoissonCache::solver(const TriangleMesh& mesh, const std::vector<char>& isFixed,
                                                          bool* factorised) {
  std::string key;
  key.reserve(mesh.positions.size() * sizeof(Vec3) + mesh.triangles.size() * sizeof(std::array<int, 3>) +
              isFixed.size());
  key.append(reinterpret_cast<const char*>(mesh.positions.data()), mesh.positions.size() * sizeof(Vec3));
  key.append(reinterpret_cast<const char*>(mesh.triangles.data()), mesh.triangles.size() * sizeof(std::array<int, 3>));
  key.append(isFixed.data(), isFixed.size());
  if (factorised) *factorised = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = current_.find(key);
    if (it == current_.end()) {
      const auto kept = previous_.find(key);
      if (kept != previous_.end()) it = current_.emplace(std::move(key), kept->second).first;
    }
    if (it != current_.end()) {
      ++reused;
      return it->second;
    }
  }
  // Factorised outside the lock: other threads' lookups and factorisations go on meanwhile.
  auto out = std::make_shared<const PoissonSolver>(mesh, isFixed);
  std::lock_guard<std::mutex> lock(mutex_);
  ++made;
  if (factorised) *factorised = true;
  return current_.emplace(std::move(key), out).first->second;  // the first made wins (they are the same)
}

void PoissonCache::endRun() {
  previous_ = std::move(current_);
  current_.clear();
  reused = made = 0;
}

}  // namespace montage
