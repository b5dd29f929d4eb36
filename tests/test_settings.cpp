// Settings that read their own options (set_from_options): the model input (io::ModelInput), the
// Craig-Bampton settings, the static settings, the export options, select's settings and the box
// generator; each records a bad value in its error (or throws from check()) naming the option.
#include <petscsys.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/io/export.hpp"
#include "morse/io/matrix_model.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/nastran.hpp"
#include "morse/select/select.hpp"
#include "util.hpp"

namespace {

using morse::test::GivenOptions;

std::string check_error(const morse::io::ModelInput& in, const char* needs_mesh = nullptr) {
  try {
    in.check(needs_mesh);
  } catch (const morse::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Settings, ModelInputFillsMeshAndMatrixInput) {
  GivenOptions g{{"-mesh", "a.msh"},      {"-mesh_units", "mm-t-s"},  {"-clamp", "root,hub"},
                 {"-material_E", "2e11"}, {"-mesh_node_sets", "tip"}, {"-mesh_node_set_tip", "1,3,7-9"}};
  morse::io::ModelInput in;
  ASSERT_EQ(in.set_from_options(PETSC_COMM_WORLD, "x.h5"), 0);
  EXPECT_EQ(in.mesh.path, "a.msh");
  EXPECT_EQ(in.out, "x.h5");
  EXPECT_EQ(in.mesh.units, "mm-t-s");
  EXPECT_EQ(in.matrices.units, "mm-t-s");
  EXPECT_EQ(in.mesh.clamp, (std::vector<std::string>{"root", "hub"}));
  EXPECT_EQ(in.matrices.clamp, in.mesh.clamp);
  EXPECT_EQ(in.mesh.material.E, 2e11);
  EXPECT_EQ(in.mesh.material.nu, -1);
  ASSERT_EQ(in.mesh.node_sets.size(), 1u);
  EXPECT_EQ(in.mesh.node_sets[0].second, (std::vector<std::int64_t>{1, 3, 7, 8, 9}));
  EXPECT_EQ(in.matrices.node_sets, in.mesh.node_sets);
  EXPECT_FALSE(in.matrices_given());
  EXPECT_EQ(check_error(in), "");
  EXPECT_TRUE(morse::options::registered("-mesh_node_set_tip"));
}

TEST(Settings, ModelInputChecks) {
  {
    GivenOptions g{{"-mesh_node_sets", "tip"}, {"-mesh_node_set_tip", "1,x"}};
    morse::io::ModelInput in;
    ASSERT_EQ(in.set_from_options(PETSC_COMM_WORLD, "x.h5"), 0);
    EXPECT_EQ(check_error(in), "-mesh_node_set_tip: 'x' is not a node id or a range a-b");
  }
  {
    GivenOptions g{{"-matrices_K", "K.mtx"}, {"-matrices_M", "M.mtx"}, {"-material_rho", "7800"}};
    morse::io::ModelInput in;
    ASSERT_EQ(in.set_from_options(PETSC_COMM_WORLD, "x.h5"), 0);
    EXPECT_TRUE(in.matrices_given());
    EXPECT_NE(check_error(in, "static needs a mesh").find("static needs a mesh; "), std::string::npos);
    EXPECT_EQ(check_error(in), "-material_* options need a mesh: the matrices already hold the material");
  }
  morse::io::ModelInput none;
  EXPECT_NE(check_error(none).find("no model given"), std::string::npos);
}

TEST(Settings, CraigBamptonReadsItsOptions) {
  GivenOptions g{{"-boundary", "LE"}, {"-cb_fmax", "5000"}, {"-cb_damping", "0.01"}, {"-cb_write_basis", "1"}};
  morse::cb::CBSettings s;
  ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), 0);
  EXPECT_EQ(s.boundary_set, "LE");
  EXPECT_EQ(s.fmax_hz, 5000);
  EXPECT_EQ(s.n_fixed, -1);
  EXPECT_EQ(s.damping, 0.01);
  EXPECT_TRUE(s.keep_basis);
  std::string b = "kept";
  morse::options::clear();
  PetscOptionsClearValue(nullptr, "-boundary");
  ASSERT_EQ(morse::cb::read_boundary_option(PETSC_COMM_WORLD, &b), 0);
  EXPECT_EQ(b, "kept");
}

TEST(Settings, StaticRecordsABadValue) {
  GivenOptions g{{"-static_steps", "0"}, {"-static_linear", "1"}};
  morse::dyn::StaticSettings s;
  ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), 0);
  EXPECT_TRUE(s.linear);
  EXPECT_EQ(s.error, "-static_steps must be positive (got 0)");
}

TEST(Settings, ExportOptions) {
  {
    GivenOptions g{{"-export_from", "se.h5"}, {"-export_format", "op4,mtx"}, {"-export_op4_names", "KX,MX"}};
    morse::io::ExportOptions o;
    ASSERT_EQ(o.set_from_options(PETSC_COMM_WORLD), 0);
    EXPECT_EQ(o.error, "");
    EXPECT_EQ(o.prefix, "se");
    EXPECT_TRUE(o.op4 && o.mtx && !o.mbdyn && !o.dmig);
    EXPECT_EQ(o.names.op4_K, "KX");
    EXPECT_EQ(o.names.op4_C, "BAA");
  }
  GivenOptions g{{"-export_format", "mbdyn,fem"}};
  morse::io::ExportOptions o;
  ASSERT_EQ(o.set_from_options(PETSC_COMM_WORLD), 0);
  EXPECT_EQ(o.error, "-export_format fem: unknown format (mbdyn, op4, dmig, mtx)");
}

TEST(Settings, SelectSettings) {
  {
    GivenOptions g{{"-select_method", "eim,lpf"}, {"-select_num_modes", "4"}};
    morse::select::Settings s;
    ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), 0);
    EXPECT_EQ(s.error, "");
    EXPECT_EQ(s.verify.names, (std::vector<std::string>{"eim", "lpf"}));
    ASSERT_EQ(s.verify.methods.size(), 2u);
    EXPECT_EQ(s.verify.methods[1], morse::select::Method::LPF);
    EXPECT_EQ(s.verify.num_modes, 4);
    EXPECT_EQ(s.verify.fraction, -1);
    EXPECT_EQ(s.rom_method, "eim");
  }
  {
    morse::select::Settings s;
    ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), 0);
    morse::options::clear();
    EXPECT_EQ(s.verify.fraction, 0.95);
    EXPECT_EQ(s.verify.names, (std::vector<std::string>{"eim"}));
  }
  GivenOptions g{{"-select_method", "eim,eim"}};
  morse::select::Settings s;
  ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), 0);
  EXPECT_EQ(s.error, "-select_method lists eim twice");
}

TEST(Settings, BoxSpec) {
  GivenOptions g{{"-box_type", "tet4"}, {"-box_nx", "3"}};
  morse::mesh::BoxSpec b;
  std::string error;
  ASSERT_EQ(morse::mesh::box_spec_from_options(PETSC_COMM_WORLD, &b, &error), 0);
  EXPECT_EQ(error, "");
  EXPECT_EQ(b.type, morse::mesh::ElementType::Tet4);
  EXPECT_EQ(b.nx, 3);
  PetscOptionsSetValue(nullptr, "-box_type", "hex27");
  ASSERT_EQ(morse::mesh::box_spec_from_options(PETSC_COMM_WORLD, &b, &error), 0);
  EXPECT_EQ(error, "-box_type hex27: unknown element type (tet4 tet10 wedge6 wedge15 hex8 hex20)");
}

TEST(Settings, NastranWriteOptions) {
  GivenOptions g{{"-nastran_format", "free"}, {"-nastran_spc", "x0"}, {"-material_rho", "7800"}};
  morse::mesh::NastranWriteOptions o;
  ASSERT_EQ(o.set_from_options(PETSC_COMM_WORLD), 0);
  EXPECT_EQ(o.error, "");
  EXPECT_EQ(o.format, morse::mesh::NastranWriteOptions::Format::Free);
  EXPECT_EQ(o.spc, "x0");
  EXPECT_EQ(o.material.rho, 7800);
  EXPECT_EQ(o.material.E, -1);
  PetscOptionsSetValue(nullptr, "-nastran_format", "wide");
  ASSERT_EQ(o.set_from_options(PETSC_COMM_WORLD), 0);
  EXPECT_EQ(o.error, "-nastran_format wide: expected large, small or free");
}
