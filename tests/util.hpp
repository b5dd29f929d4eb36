// Shared helpers of the morse unit tests.
#pragma once

#include <petscsys.h>
#include <mpi.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "given_options.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/options.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/fe/model.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::test {

inline mesh::Material steel() {
  mesh::Material m;
  m.name = "steel";
  m.E = 2.1e11;
  m.nu = 0.3;
  m.rho = 7800;
  return m;
}

/// A box of type with the given dimensions [m] and cells.
inline mesh::BoxSpec box_spec(mesh::ElementType type, double lx, double ly, double lz, int nx, int ny, int nz) {
  mesh::BoxSpec b;
  b.type = type;
  b.lx = lx;
  b.ly = ly;
  b.lz = lz;
  b.nx = nx;
  b.ny = ny;
  b.nz = nz;
  return b;
}

/// Generates a box on rank 0 of comm and distributes it. Collective.
inline mesh::LocalMesh box_mesh(MPI_Comm comm, const mesh::BoxSpec& b) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  mesh::Mesh m;
  if (rank == 0) m = mesh::generate_box(b);
  return mesh::distribute(comm, &m);
}

/// A distributed box with its DOF map and assembled K, M.
struct Model {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
};

/// Generates and distributes box b, clamps the given sets and assembles with `material`
/// (default steel). Collective.
inline Model assembled_box(MPI_Comm comm, const mesh::BoxSpec& b, const std::vector<std::string>& clamp = {"x0"},
                           const mesh::Material& material = steel()) {
  Model m;
  m.lm = box_mesh(comm, b);
  m.dofs = fe::number_dofs(m.lm, clamp);
  m.ops = fe::assemble(m.lm, m.dofs, material);
  return m;
}

/// An fe::Model over a test's parts: copies of the mesh and layout, and new references to K and
/// M (the same Mat objects). Not collective.
inline fe::Model model_of(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const fe::Operators& ops) {
  fe::Model md;
  md.mesh = lm;
  md.dofs = dofs;
  for (Mat A : {ops.K.get(), ops.M.get()}) MORSE_CALL(PetscObjectReference(reinterpret_cast<PetscObject>(A)));
  md.K = UMat(ops.K.get());
  md.M = UMat(ops.M.get());
  md.volume = ops.volume;
  md.mass = ops.mass;
  md.units = lm.mesh.units;
  md.source = lm.mesh.source;
  return md;
}
inline fe::Model model_of(const Model& m) { return model_of(m.lm, m.dofs, m.ops); }

/// Craig–Bampton of an assembled model with the basis kept: `boundary` as the physical nodes and
/// `n_fixed` fixed-interface modes. Collective.
inline cb::CBResult cb_basis(const Model& m, const std::string& boundary, PetscInt n_fixed) {
  cb::CBSettings cs;
  cs.boundary_set = boundary;
  cs.n_fixed = n_fixed;
  cs.keep_basis = true;
  return cb::craig_bampton(model_of(m), cs);
}

/// A DOF vector from a nodal field f(x, y, z, d) on the free DOFs.
template <class F>
UVec nodal_vector(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, F f) {
  UVec v;
  MORSE_CALL(VecCreateMPI(lm.comm, dofs.n_owned, dofs.n_global, v.ptr()));
  PetscScalar* a;
  MORSE_CALL(VecGetArray(v.get(), &a));
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k) {
    if (lm.node_owner[k] != rank) continue;
    const double* x = &lm.mesh.coords[3 * k];
    for (int d = 0; d < 3; ++d) {
      PetscInt g = dofs.node_dof[3 * k + d];
      if (g >= 0) a[g - dofs.first] = f(x[0], x[1], x[2], d);
    }
  }
  MORSE_CALL(VecRestoreArray(v.get(), &a));
  return v;
}

/// Mass-weighted MAC between a vector a and a vector b: (a^T M b)^2 / (a^T M a b^T M b).
inline double mac(Mat M, Vec a, Vec b) {
  UVec Ma, Mb;
  MORSE_CALL(VecDuplicate(a, Ma.ptr()));
  MORSE_CALL(VecDuplicate(b, Mb.ptr()));
  MORSE_CALL(MatMult(M, a, Ma.get()));
  MORSE_CALL(MatMult(M, b, Mb.get()));
  PetscScalar ab, aa, bb;
  MORSE_CALL(VecDot(Ma.get(), b, &ab));
  MORSE_CALL(VecDot(Ma.get(), a, &aa));
  MORSE_CALL(VecDot(Mb.get(), b, &bb));
  return ab * ab / (aa * bb);
}

/// The whole matrix, row-major, on every rank.
inline std::vector<double> dense_matrix(Mat A) {
  PetscInt n = 0, rs = 0, re = 0;
  MORSE_CALL(MatGetSize(A, &n, nullptr));
  MORSE_CALL(MatGetOwnershipRange(A, &rs, &re));
  std::vector<double> d(static_cast<std::size_t>(n) * n, 0.0);
  for (PetscInt r = rs; r < re; ++r) {
    PetscInt nc;
    const PetscInt* cols;
    const PetscScalar* vals;
    MORSE_CALL(MatGetRow(A, r, &nc, &cols, &vals));
    for (PetscInt k = 0; k < nc; ++k) d[r * n + cols[k]] = PetscRealPart(vals[k]);
    MORSE_CALL(MatRestoreRow(A, r, &nc, &cols, &vals));
  }
  MPI_Allreduce(MPI_IN_PLACE, d.data(), static_cast<int>(d.size()), MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  return d;
}

/// The lowest n eigenvalues of (K, M) by LAPACK's dense generalized solver (sygv), on every
/// rank; 0 entries if LAPACK fails (info != 0). For small models. Collective.
inline std::vector<double> lowest_eigenvalues(Mat K, Mat M, int n) {
  auto k = dense_matrix(K), m = dense_matrix(M);
  PetscInt N = 0;
  MORSE_CALL(MatGetSize(K, &N, nullptr));
  PetscBLASInt bn = static_cast<PetscBLASInt>(N), itype = 1, info = 0, lwork = 8 * bn;
  std::vector<double> w(N), work(lwork);
  LAPACKsygv_(&itype, "N", "U", &bn, k.data(), &bn, m.data(), &bn, w.data(), work.data(), &lwork, &info);
  if (info != 0) w.assign(N, 0.0);
  w.resize(n);
  return w;
}

/// Solves A x = b with a MUMPS LU/Cholesky (KSPPREONLY). Collective.
inline void direct_solve(Mat A, Vec b, Vec x) {
  UKSP ksp;
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)A, &comm));
  MORSE_CALL(KSPCreate(comm, ksp.ptr()));
  MORSE_CALL(KSPSetOperators(ksp.get(), A, A));
  MORSE_CALL(KSPSetType(ksp.get(), KSPPREONLY));
  PC pc;
  MORSE_CALL(KSPGetPC(ksp.get(), &pc));
  MORSE_CALL(PCSetType(pc, PCCHOLESKY));
  MORSE_CALL(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  MORSE_CALL(KSPSolve(ksp.get(), b, x));
}

// Rank independence of a history recorded on one rank (serial) and on all ranks (all): rows of
// 4 values, three displacements then an energy, each kind against its largest magnitude. Returns
// "" if they agree to rtol, else what differs; *energy_scale (if given) gets the largest energy.
inline std::string history_rank_difference(const std::vector<double>& serial, const std::vector<double>& all,
                                           double rtol, double* energy_scale = nullptr) {
  if (serial.size() != all.size())
    return cat("1 rank recorded ", serial.size(), " values, all ranks ", all.size(), "; ");
  double scale[2] = {0, 0}, diff[2] = {0, 0};
  for (std::size_t i = 0; i < all.size(); ++i) {
    const int q = i % 4 == 3 ? 1 : 0;
    scale[q] = std::max(scale[q], std::abs(serial[i]));
    diff[q] = std::max(diff[q], std::abs(serial[i] - all[i]));
  }
  if (energy_scale) *energy_scale = scale[1];
  std::string msg;
  for (int q = 0; q < 2; ++q)
    if (!(diff[q] <= rtol * scale[q]))
      msg += cat(q ? "energy" : "displacement", ": 1 rank vs all ranks differ by ", diff[q], " of ", scale[q], "; ");
  return msg;
}

}  // namespace morse::test
