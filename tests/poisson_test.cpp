// Poisson / harmonic interpolation on meshes (core/poisson.h).
#include "geometry/poisson.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <random>

#include "geometry/shapes.h"
#include "test_support.h"

using namespace montage;

namespace {

// Boundary vertices of an nx x ny grid as produced by makeGrid.
std::vector<char> gridBoundary(int nx, int ny) {
  std::vector<char> fixed(size_t(nx) * ny, 0);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      if (i == 0 || j == 0 || i == nx - 1 || j == ny - 1) fixed[size_t(j) * nx + i] = 1;
  return fixed;
}

double testF(double x, double y) {
  return std::sin(M_PI * x) * std::sin(M_PI * y) + x * x;
}
double testLaplacianF(double x, double y) {
  return -2 * M_PI * M_PI * std::sin(M_PI * x) * std::sin(M_PI * y) + 2;
}

// Unit-square grid with n vertices per side; interior vertices jittered by up to `jitter` spacings per axis.
std::unique_ptr<Mesh> unitGrid(int n, double jitter, unsigned seed) {
  const double h = 1.0 / (n - 1);
  if (jitter == 0) return makeGrid(n, n, h);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  std::vector<Vec3> v;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      Vec3 p(i * h, j * h, 0);
      if (i > 0 && j > 0 && i < n - 1 && j < n - 1) p += Vec3(u(rng) * h, u(rng) * h, 0);
      v.push_back(p);
    }
  std::vector<std::array<int, 3>> f;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      f.push_back({a, b, d});
      f.push_back({a, d, c});
    }
  return requireUsable(buildMesh(v, f));
}

// Max vertex error of the Poisson solve of Delta f = testLaplacianF with boundary values testF.
double poissonError(const Mesh& mesh, int n) {
  const int nv = mesh.numVertices();
  Eigen::MatrixXd d(nv, 1), exact(nv, 1);
  for (int v = 0; v < nv; ++v) {
    const Vec3 p = mesh.position(v);
    d(v, 0) = testLaplacianF(p.x(), p.y());
    exact(v, 0) = testF(p.x(), p.y());
  }
  const PoissonSolver solver(mesh, gridBoundary(n, n));
  const Eigen::MatrixXd f = solver.solve(d, exact);
  return (f - exact).cwiseAbs().maxCoeff();
}

}  // namespace

TEST(Poisson, LaplacianIsSymmetricPsdWithZeroRowSums) {
  const auto mesh = makeIcosphere(2);
  const Eigen::SparseMatrix<double> L = cotangentLaplacian(*mesh);
  const Eigen::MatrixXd dense(L);
  EXPECT_LT((dense - dense.transpose()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((dense * Eigen::VectorXd::Ones(dense.cols())).cwiseAbs().maxCoeff(), 1e-10);
  const Eigen::VectorXd eig = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues();
  EXPECT_GT(eig.minCoeff(), -1e-10);
  EXPECT_NEAR(
      vertexAreas(*mesh).sum(),
      [&] {
        double a = 0;
        for (int f = 0; f < mesh->numFaces(); ++f) a += mesh->faceArea(f);
        return a;
      }(),
      1e-12);
}

TEST(Poisson, SignConventionQuadraticHasLaplacianFour) {
  // f = x^2 + y^2: -M^-1 L f must be +4 at interior vertices of a flat regular grid.
  const int n = 21;
  const auto mesh = makeGrid(n, n, 1.0 / (n - 1));
  Eigen::VectorXd f(mesh->numVertices());
  for (int v = 0; v < mesh->numVertices(); ++v) f[v] = mesh->position(v).squaredNorm();
  const Eigen::VectorXd lap = -(cotangentLaplacian(*mesh) * f).cwiseQuotient(vertexAreas(*mesh));
  const auto fixed = gridBoundary(n, n);
  for (int v = 0; v < mesh->numVertices(); ++v)
    if (!fixed[v]) EXPECT_NEAR(lap[v], 4.0, 1e-9) << "vertex " << v;
}

TEST(Poisson, HarmonicFillReproducesLinearRamp) {
  const int n = 41;
  const auto mesh = makeGrid(n, n, 1.0 / (n - 1));
  const int nv = mesh->numVertices();
  Eigen::MatrixXd exact(nv, 3), given(nv, 3);
  const auto fixed = gridBoundary(n, n);
  for (int v = 0; v < nv; ++v) {
    const Vec3 p = mesh->position(v);
    exact.row(v) << 0.2 + 0.5 * p.x() - 0.3 * p.y(), 0.7 - 0.4 * p.x() + 0.1 * p.y(), 0.5 + 0.25 * p.x() + 0.25 * p.y();
    given.row(v) = fixed[v] ? exact.row(v) : Eigen::RowVector3d(9, -9, 42);  // unknown rows are ignored
  }
  const Eigen::MatrixXd f = harmonicFill(*mesh, fixed, given);
  const double err = (f - exact).cwiseAbs().maxCoeff();
  std::printf("linear ramp max error %.3g\n", err);
  EXPECT_LT(err, 1e-9);
}

TEST(Poisson, ConvergesOnRegularGrid) {
  double prev = 0;
  for (int n : {11, 21, 41, 81}) {
    const double err = poissonError(*unitGrid(n, 0, 0), n);
    std::printf("regular grid n=%d max error %.4g%s\n", n, err,
                prev > 0 ? (" ratio " + std::to_string(prev / err)).c_str() : "");
    if (prev > 0) EXPECT_LT(err, 0.6 * prev) << "n = " << n;
    prev = err;
  }
  EXPECT_LT(prev, 1e-3);
}

TEST(Poisson, ConvergesOnJitteredGrid) {
  double prev = 0;
  for (int n : {11, 21, 41, 81}) {
    const auto mesh = unitGrid(n, 0.3, 1234 + n);
    for (int f = 0; f < mesh->numFaces(); ++f) ASSERT_GT(mesh->faceNormal(f).z(), 0.5) << "flipped face " << f;
    const double err = poissonError(*mesh, n);
    std::printf("jittered grid n=%d max error %.4g%s\n", n, err,
                prev > 0 ? (" ratio " + std::to_string(prev / err)).c_str() : "");
    if (prev > 0) EXPECT_LT(err, 0.75 * prev) << "n = " << n;
    prev = err;
  }
  EXPECT_LT(prev, 5e-3);
}

TEST(Poisson, SolverReuseMatchesFreshSolvers) {
  const int n = 25;
  const auto mesh = makeGrid(n, n, 1.0 / (n - 1));
  const int nv = mesh->numVertices();
  const auto fixed = gridBoundary(n, n);
  const PoissonSolver solver(*mesh, fixed);
  EXPECT_EQ(solver.unknowns(), (n - 2) * (n - 2));
  EXPECT_GE(solver.factorSeconds(), 0.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd all_d(nv, 3), all_b(nv, 3);
  for (int k = 0; k < 3; ++k) {
    Eigen::MatrixXd d(nv, 1), b(nv, 1);
    for (int v = 0; v < nv; ++v) d(v, 0) = u(rng), b(v, 0) = u(rng);
    all_d.col(k) = d.col(0), all_b.col(k) = b.col(0);
    const Eigen::MatrixXd reused = solver.solve(d, b);
    const Eigen::MatrixXd fresh = PoissonSolver(*mesh, fixed).solve(d, b);
    EXPECT_LT((reused - fresh).cwiseAbs().maxCoeff(), 1e-12) << "rhs " << k;
    for (int v = 0; v < nv; ++v)
      if (fixed[v]) EXPECT_EQ(reused(v, 0), b(v, 0));
  }
  // All channels at once equal channel by channel.
  const Eigen::MatrixXd together = solver.solve(all_d, all_b);
  for (int k = 0; k < 3; ++k)
    EXPECT_LT((together.col(k) - solver.solve(all_d.col(k), all_b.col(k))).cwiseAbs().maxCoeff(), 1e-12);
  // Size mismatches are reported.
  EXPECT_NE(test::errorOf([&] { solver.solve(Eigen::MatrixXd::Zero(nv, 2), all_b); }), "");
  EXPECT_NE(test::errorOf([&] { solver.solve(all_d, Eigen::MatrixXd::Zero(nv - 1, 3)); }), "");
}

TEST(Poisson, ComponentWithoutFixedVertexThrows) {
  const auto sphere = makeIcosphere(1);  // 42 vertices, closed
  const std::string msg = test::errorOf([&] { PoissonSolver(*sphere, std::vector<char>(42, 0)); });
  EXPECT_NE(msg.find("42 unknown vertices"), std::string::npos) << msg;
  std::vector<char> one(42, 0);
  one[5] = 1;
  EXPECT_NO_THROW(PoissonSolver(*sphere, one));

  // Two disjoint 3x3 grids; only the first has fixed vertices: the 9 vertices of the second are named.
  std::vector<Vec3> v;
  std::vector<std::array<int, 3>> f;
  for (int g = 0; g < 2; ++g) {
    const int base = static_cast<int>(v.size());
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) v.emplace_back(i + 10.0 * g, j, 0);
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const int a = base + j * 3 + i;
        f.push_back({a, a + 1, a + 4});
        f.push_back({a, a + 4, a + 3});
      }
  }
  const auto two = requireUsable(buildMesh(v, f));
  std::vector<char> fixed(18, 0);
  for (int k = 0; k < 9; ++k) fixed[k] = k != 4;
  const std::string msg2 = test::errorOf([&] { PoissonSolver(*two, fixed); });
  EXPECT_NE(msg2.find("9 unknown vertices"), std::string::npos) << msg2;
  EXPECT_NE(test::errorOf([&] { PoissonSolver(*two, std::vector<char>(3, 0)); }), "");
}

TEST(Poisson, NearDegenerateTriangleStaysFinite) {
  const int n = 11;
  const double h = 1.0 / (n - 1);
  const auto fixed = gridBoundary(n, n);
  for (double eps : {1e-10, 0.0}) {
    auto mesh = makeGrid(n, n, h);
    // Vertex (5,5) moved almost onto the edge (4,4)-(4,5) opposite it in triangle (4,4),(5,5),(4,5).
    mesh->tri.set_point(mesh->tri.vertex_handle(5 * n + 5), OpenMesh::Vec3d((4 + eps) * h, 4.5 * h, 0));
    const Eigen::SparseMatrix<double> L = cotangentLaplacian(*mesh);
    for (int k = 0; k < L.outerSize(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(L, k); it; ++it)
        ASSERT_TRUE(std::isfinite(it.value())) << "eps " << eps;
    const int nv = mesh->numVertices();
    Eigen::MatrixXd b(nv, 1), d(nv, 1);
    for (int v = 0; v < nv; ++v) {
      const Vec3 p = mesh->position(v);
      b(v, 0) = 0.3 + p.x() - 2 * p.y();
      d(v, 0) = testLaplacianF(p.x(), p.y());
    }
    const Eigen::MatrixXd hf = harmonicFill(*mesh, fixed, b);
    ASSERT_TRUE(hf.allFinite()) << "eps " << eps;
    // Clamping the sliver's cotangents costs linear precision next to it (the exact weights would cancel),
    // but the fill stays bounded by the boundary values and exact away from the sliver.
    EXPECT_LE(hf.maxCoeff(), b.maxCoeff() + 1e-9) << "eps " << eps;
    EXPECT_GE(hf.minCoeff(), b.minCoeff() - 1e-9) << "eps " << eps;
    for (int v = 0; v < nv; ++v)
      if ((mesh->position(v) - Vec3(4.5 * h, 4.5 * h, 0)).norm() > 3 * h)
        EXPECT_LT(std::abs(hf(v, 0) - b(v, 0)), 0.05) << "vertex " << v << ", eps " << eps;
    const Eigen::MatrixXd pf = PoissonSolver(*mesh, fixed).solve(d, b);
    EXPECT_TRUE(pf.allFinite()) << "eps " << eps;
  }
}
