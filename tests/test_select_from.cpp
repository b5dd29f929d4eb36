// `morse select -select_from`: the superelement basis written by `morse reduce -cb_write_basis`
// and read back gives the same reduced operators as the one computed directly, also on a model
// with a six-DOF interface point (an RBE3 spider: its DOFs are written beside the nodal shapes).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>

#include "morse/app/commands.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/session.hpp"
#include "morse/mesh/gmsh.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;

namespace {

// The beam both tests reduce: 8 x 2 x 1 hex20, 1 m x 0.08 m x 0.05 m.
mesh::BoxSpec beam() {
  mesh::BoxSpec b;
  b.type = mesh::ElementType::Hex20;
  b.lx = 1.0;
  b.ly = 0.08;
  b.lz = 0.05;
  b.nx = 8;
  b.ny = 2;
  b.nz = 1;
  return b;
}

// Writes it (steel) as a Gmsh file on rank 0; collective.
void write_beam(MPI_Comm comm, const mesh::BoxSpec& b, const std::string& path) {
  if (world_rank() == 0) {
    auto m = mesh::generate_box(b);
    m.materials.push_back(test::steel());
    std::fill(m.elem_material.begin(), m.elem_material.end(), 0);
    mesh::write_gmsh(m, path);
  }
  MPI_Barrier(comm);
}

}  // namespace

TEST(SelectFrom, BasisFileRoundTrip) {
  MPI_Comm comm = PETSC_COMM_WORLD;
  const test::SharedScratchDir scratch("select_from");
  const std::string base = scratch.path("box");
  const mesh::BoxSpec b = beam();
  write_beam(comm, b, base + ".msh");
  const std::vector<std::pair<std::string, std::string>> opts = {
      {"-mesh", base + ".msh"},    {"-clamp", "x0"},      {"-boundary", "x1"},   {"-cb_num_fixed_modes", "6"},
      {"-cb_write_basis", "true"}, {"-cb_xdmf", "false"}, {"-out", base + ".h5"}};
  for (const auto& [k, v] : opts) MORSE_CALL(PetscOptionsSetValue(nullptr, k.c_str(), v.c_str()));
  app::run_command(comm, "reduce", {});
  for (const auto& [k, v] : opts) MORSE_CALL(PetscOptionsClearValue(nullptr, k.c_str()));

  auto lm = mesh::read_and_distribute(comm, base + ".msh");
  auto dofs = fe::number_dofs(lm, {"x0"});
  auto ops = fe::assemble(lm, dofs, mesh::Material{});
  cb::CBSettings s;
  s.boundary_set = "x1";
  s.n_fixed = 6;
  auto direct = cb::craig_bampton(test::model_of(lm, dofs, ops), s);
  auto loaded = cb::load_basis(test::model_of(lm, dofs, ops), base + ".h5", "x1", 0.0);
  ASSERT_EQ(direct.n(), loaded.n());
  double kref = 0, mref = 0, kerr = 0, merr = 0;
  for (std::size_t i = 0; i < direct.K.size(); ++i) {
    kref = std::max(kref, std::abs(direct.K[i]));
    mref = std::max(mref, std::abs(direct.M[i]));
    kerr = std::max(kerr, std::abs(direct.K[i] - loaded.K[i]));
    merr = std::max(merr, std::abs(direct.M[i] - loaded.M[i]));
  }
  EXPECT_LT(kerr, 1e-12 * kref);
  EXPECT_LT(merr, 1e-12 * mref);
  // The file's eigenvalues against a second solve: equal to round-off, not bitwise (two solves
  // may round differently, e.g. with BLAS kernels chosen by data alignment).
  ASSERT_EQ(direct.fixed_omega2.size(), loaded.fixed_omega2.size());
  for (std::size_t i = 0; i < direct.fixed_omega2.size(); ++i)
    EXPECT_NEAR(direct.fixed_omega2[i], loaded.fixed_omega2[i], 1e-10 * std::abs(direct.fixed_omega2[i])) << i;
  // A missing file is refused, naming it.
  try {
    cb::load_basis(test::model_of(lm, dofs, ops), base + "_missing.h5", "x1", 0.0);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(base + "_missing.h5"), std::string::npos) << e.what();
  }
}

TEST(SelectFrom, BasisFileRoundTripWithASixDofPoint) {
  MPI_Comm comm = PETSC_COMM_WORLD;
  const test::SharedScratchDir scratch("select_from_point");
  const std::string base = scratch.path("box");
  const mesh::BoxSpec b = beam();
  // The tip face's centre node (a mid-edge node at y = 0.04, z = 0.025) carries the spider.
  std::int64_t centre = -1;
  {
    const auto m = mesh::generate_box(b);
    for (std::int64_t k = 0; k < m.num_nodes(); ++k)
      if (std::abs(m.coords[3 * k] - 1.0) < 1e-12 && std::abs(m.coords[3 * k + 1] - 0.04) < 1e-12 &&
          std::abs(m.coords[3 * k + 2] - 0.025) < 1e-12)
        centre = m.node_ids[k];
  }
  ASSERT_GT(centre, 0);
  write_beam(comm, b, base + ".msh");
  const std::vector<std::pair<std::string, std::string>> opts = {
      {"-mesh", base + ".msh"},      {"-clamp", "x0"},
      {"-mesh_node_sets", "tipc"},   {"-mesh_node_set_tipc", std::to_string(centre)},
      {"-mesh_spiders", "tipc"},     {"-mesh_spider_radius", "0.1"},
      {"-boundary", "tipc_spiders"}, {"-cb_num_fixed_modes", "6"},
      {"-cb_write_basis", "true"},   {"-cb_xdmf", "false"},
      {"-out", base + ".h5"}};
  for (const auto& [k, v] : opts) MORSE_CALL(PetscOptionsSetValue(nullptr, k.c_str(), v.c_str()));
  app::run_command(comm, "reduce", {});
  for (const auto& [k, v] : opts) MORSE_CALL(PetscOptionsClearValue(nullptr, k.c_str()));

  fe::MeshInput in;
  in.path = base + ".msh";
  in.clamp = {"x0"};
  in.node_sets = {{"tipc", {centre}}};
  in.spider_sets = {"tipc"};
  in.spider_radius = 0.1;
  auto md = fe::mesh_model(comm, in);
  ASSERT_TRUE(md.constraints);
  ASSERT_EQ(md.constraints->n_point_dofs, 6);
  // The tip face's own set names the point too (a point joins T_spiders of its centre's sets).
  EXPECT_EQ(md.mesh->node_set_sizes.at("x1_spiders"), 1);
  cb::CBSettings s;
  s.boundary_set = "tipc_spiders";
  s.n_fixed = 6;
  auto direct = cb::craig_bampton(md, s);
  auto loaded = cb::load_basis(md, base + ".h5", "tipc_spiders", 0.0);
  ASSERT_EQ(direct.n(), loaded.n());
  ASSERT_EQ(direct.n_b, 6);
  double kref = 0, mref = 0, kerr = 0, merr = 0;
  for (std::size_t i = 0; i < direct.K.size(); ++i) {
    kref = std::max(kref, std::abs(direct.K[i]));
    mref = std::max(mref, std::abs(direct.M[i]));
    kerr = std::max(kerr, std::abs(direct.K[i] - loaded.K[i]));
    merr = std::max(merr, std::abs(direct.M[i] - loaded.M[i]));
  }
  EXPECT_LT(kerr, 1e-10 * kref);
  EXPECT_LT(merr, 1e-10 * mref);
  // The point's rows matter: the boundary block of K is the point's 6 x 6 static stiffness, not 0.
  EXPECT_GT(std::abs(loaded.K[0]), 1e-3 * kref);
}
