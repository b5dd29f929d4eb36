// The option registry and the unknown-option check derived from it (morse/core/options.hpp).
#include <petscsys.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "given_options.hpp"
#include "morse/core/error.hpp"
#include "morse/core/options.hpp"
#include "util.hpp"

namespace {

namespace opt = morse::options;

using morse::test::GivenOptions;

// A command's option block: -casing_clearance, -contact_mu and, under prefix c1_, -load_sets.
PetscErrorCode read_options(double* clearance, double* mu) {
  PetscOptionsBegin(PETSC_COMM_WORLD, nullptr, "test options", "");
  PetscCall(MorseOptionsReal("-casing_clearance", "Casing: nominal radial clearance [m]", "", *clearance, clearance,
                             nullptr));
  PetscCall(MorseOptionsReal("-contact_mu", "Coulomb friction coefficient", "", *mu, mu, nullptr));
  PetscOptionsEnd();
  char* sets[4];
  PetscInt n = 4;
  PetscOptionsBegin(PETSC_COMM_WORLD, "c1_", "test options with a prefix", "");
  PetscCall(MorseOptionsStringArray("-load_sets", "Node sets carrying a load", "", sets, &n, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

std::string early_error() {
  try {
    opt::check_unknown(PETSC_COMM_WORLD, true);
  } catch (const morse::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Options, EditDistanceCountsTranspositionsAsOne) {
  EXPECT_EQ(opt::edit_distance("export_fromat", "export_format"), 1u);
  EXPECT_EQ(opt::edit_distance("contact_muu", "contact_mu"), 1u);
  EXPECT_EQ(opt::edit_distance("casing_clearence", "casing_clearance"), 1u);
  EXPECT_EQ(opt::edit_distance("", "abc"), 3u);
  EXPECT_EQ(opt::edit_distance("abc", "abc"), 0u);
  EXPECT_EQ(opt::edit_distance("kitten", "sitting"), 3u);
}

TEST(Options, RegistrationUnderTheBlockPrefix) {
  opt::clear();  // Session's own (-factor_repeatable)
  GivenOptions given;
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_TRUE(opt::registered("-casing_clearance"));
  EXPECT_TRUE(opt::registered("contact_mu"));
  EXPECT_TRUE(opt::registered("-c1_load_sets"));
  EXPECT_FALSE(opt::registered("-load_sets"));
  EXPECT_EQ(opt::help("-contact_mu"), "Coulomb friction coefficient");
  EXPECT_EQ(opt::names(), (std::vector<std::string>{"-c1_load_sets", "-casing_clearance", "-contact_mu"}));
  // Reading the same options again (a second command, a loop) is one registration.
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_TRUE(opt::conflicts().empty());
}

TEST(Options, OneHelpTextPerName) {
#ifndef NDEBUG
  GTEST_SKIP() << "a conflict is an assertion in debug builds";
#endif
  GivenOptions given;
  opt::add("-boundary", "Node set of the interface");
  opt::add("-boundary", "Node set of the interface");
  EXPECT_TRUE(opt::conflicts().empty());
  opt::add(nullptr, "-boundary", "Node set kept as physical DOFs");
  ASSERT_EQ(opt::conflicts().size(), 1u);
  EXPECT_NE(opt::conflicts()[0].find("-boundary registered with two help texts"), std::string::npos);
  // The early check refuses to run with a conflict.
  EXPECT_NE(early_error().find("internal error: -boundary registered with two help texts"), std::string::npos);
}

TEST(Options, ClosestSuggestsOnlyNearNames) {
  GivenOptions given;
  opt::add("-casing_clearance", "c0");
  opt::add("-casing_bump_height", "hb");
  opt::add("-contact_mu", "mu");
  opt::add("-export_format", "formats");
  opt::add("-out", "file");
  EXPECT_EQ(opt::closest("-casing_clearence"), "-casing_clearance");
  EXPECT_EQ(opt::closest("contact_muu"), "-contact_mu");
  EXPECT_EQ(opt::closest("-export_fromat"), "-export_format");
  EXPECT_EQ(opt::closest("-ot"), "-out");
  EXPECT_EQ(opt::closest("-Contact_MUU"), "-contact_mu");  // PETSc's names ignore case
  EXPECT_EQ(opt::closest("-casing_width"), "");
  EXPECT_EQ(opt::closest("-ksp_view"), "");
}

TEST(Options, SuspiciousByFirstWordOrDistanceNotInnerNorGlobal) {
  GivenOptions given;
  opt::add("-casing_clearance", "c0");
  opt::add("-cb_num_fixed_modes", "n");
  opt::add("-mesh", "file");
  opt::add_prefix("cb_", opt::Solver::Eigen);
  opt::add_prefix("static_", opt::Solver::Nonlinear);
  EXPECT_TRUE(opt::suspicious("-casing_width"));       // first word casing
  EXPECT_TRUE(opt::suspicious("-cb_num_fixed_mode"));  // first word cb, not an inner object
  EXPECT_TRUE(opt::suspicious("-mesj"));               // one edit from -mesh
  EXPECT_TRUE(opt::suspicious("-Casing_width"));       // names ignore case
  EXPECT_FALSE(opt::suspicious("-CB_EPS_TOL"));
  EXPECT_FALSE(opt::suspicious("-casing_clearance"));  // registered
  EXPECT_FALSE(opt::suspicious("-cb_eps_tol"));        // the eigen solver's EPS
  EXPECT_FALSE(opt::suspicious("-cb_st_mat_mumps_icntl_14"));
  EXPECT_FALSE(opt::suspicious("-cb_block_size"));
  EXPECT_FALSE(opt::suspicious("-cb_eigen_solver"));
  EXPECT_FALSE(opt::suspicious("-static_snes_monitor"));
  EXPECT_FALSE(opt::inner("-static_eps_tol"));    // a SNES has no EPS
  EXPECT_FALSE(opt::suspicious("-ksp_monitor"));  // an unrelated PETSc option: the final check's
  EXPECT_FALSE(opt::suspicious("-log_view"));
  EXPECT_FALSE(opt::suspicious("-malloc_debug"));
  EXPECT_FALSE(opt::suspicious("-options_left"));
  EXPECT_FALSE(opt::suspicious("-info"));
  EXPECT_FALSE(opt::suspicious("-help"));
}

TEST(Options, EarlyCheckRefusesMisspellingsNamingTheClosest) {
  GivenOptions given({{"-casing_clearence", "1e-3"}, {"-contact_mu", "0.2"}, {"-ksp_monitor", nullptr}});
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_DOUBLE_EQ(mu, 0.2);
  EXPECT_EQ(early_error(), "unknown option(s): -casing_clearence (did you mean -casing_clearance?) (see -help)");
  // The final check refuses every option nobody used, the unrelated one too.
  std::string final_error;
  try {
    opt::check_unknown(PETSC_COMM_WORLD, false);
  } catch (const morse::Error& e) {
    final_error = e.what();
  }
  EXPECT_EQ(final_error,
            "unknown option(s): -casing_clearence (did you mean -casing_clearance?) -ksp_monitor "
            "(see -help)");
}

TEST(Options, DynamicNamesAndTheirListOption) {
  // -c1_load_set (the list option misspelled) is refused, and so is the per-set option it would
  // have named.
  GivenOptions given({{"-c1_load_set", "x1"}, {"-c1_load_x1_dir", "z"}});
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_EQ(early_error(), "unknown option(s): -c1_load_set (did you mean -c1_load_sets?) -c1_load_x1_dir (see -help)");
}

TEST(Options, EarlyCheckPassesInnerAndUnrelatedOptions) {
  GivenOptions given({{"-cb_eps_tol", "1e-10"}, {"-ksp_monitor", nullptr}, {"-contact_mu", "0.2"}});
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  opt::add_prefix("cb_", opt::Solver::Eigen);
  EXPECT_EQ(early_error(), "");
}

// The text of a numeric option: integers strictly (optional sign and digits, in PetscInt's
// range: PETSc's own parsing wraps a 20-digit value to -1 and reads "default" as -2), reals whole
// and finite unless the option accepts non-finite values, lists item by item.
TEST(Options, ValueErrorNamesOptionAndText) {
  using V = opt::Value;
  for (const char* ok : {"5", "-3", "+7", "0", "2147483647"}) EXPECT_EQ(opt::value_error("-n", ok, V::Int), "") << ok;
  EXPECT_EQ(opt::value_error("-modes_nev", "5abc", V::Int), "-modes_nev 5abc: expected an integer");
  EXPECT_EQ(opt::value_error("-modes_nev", "1e3", V::Int), "-modes_nev 1e3: expected an integer");
  EXPECT_EQ(opt::value_error("-n", "2.0", V::Int), "-n 2.0: expected an integer");
  EXPECT_EQ(opt::value_error("-n", "default", V::Int), "-n default: expected an integer");
  EXPECT_EQ(opt::value_error("-n", " 5", V::Int), "-n  5: expected an integer");
  EXPECT_EQ(opt::value_error("-n", "-", V::Int), "-n -: expected an integer");
  EXPECT_EQ(opt::value_error("-modes_nev", "12345678901234567890", V::Int),
            "-modes_nev 12345678901234567890: out of the integer range [-2147483648, 2147483647]");
  EXPECT_EQ(opt::value_error("-n", "2147483648", V::Int),
            "-n 2147483648: out of the integer range [-2147483648, 2147483647]");
  EXPECT_EQ(opt::value_error("-n", "", V::Int), "-n: give a value (an integer)");
  EXPECT_EQ(opt::value_error("-n", nullptr, V::Real), "-n: give a value (a number)");
  for (const char* ok : {"1", "-2.5e-3", "1e300", "0x10", ".5"})
    EXPECT_EQ(opt::value_error("-x", ok, V::Real), "") << ok;
  EXPECT_EQ(opt::value_error("-modes_shift", "nan", V::Real), "-modes_shift nan: expected a finite number");
  EXPECT_EQ(opt::value_error("-x", "-inf", V::Real), "-x -inf: expected a finite number");
  EXPECT_EQ(opt::value_error("-x", "1e400", V::Real), "-x 1e400: expected a finite number");
  EXPECT_EQ(opt::value_error("-x", "abc", V::Real), "-x abc: expected a real number");
  EXPECT_EQ(opt::value_error("-x", "1.5x", V::Real), "-x 1.5x: expected a real number");
  EXPECT_EQ(opt::value_error("-x", "nan", V::RealNonFinite), "");
  EXPECT_EQ(opt::value_error("-x", "inf", V::RealNonFinite), "");
  EXPECT_EQ(opt::value_error("-x", "inf?", V::RealNonFinite), "-x inf?: expected a real number");
  EXPECT_EQ(opt::value_error("-r", "1,2.5,-3e2", V::RealArray), "");
  EXPECT_EQ(opt::value_error("-r", "1,nan", V::RealArray), "-r 1,nan: item 'nan': expected a finite number");
  EXPECT_EQ(opt::value_error("-r", "1,,2", V::RealArray), "-r 1,,2: item '': expected a real number");
  EXPECT_EQ(opt::value_error("-i", "1,3-5,-2", V::IntArray), "");
  EXPECT_EQ(opt::value_error("-i", "1,2.5", V::IntArray), "-i 1,2.5: item '2.5': expected an integer");
  EXPECT_EQ(opt::value_error("-i", "1-x", V::IntArray), "-i 1-x: item '1-x': expected an integer");
  EXPECT_EQ(opt::magnitude_error("-material_E", 2.1e11), "");
  EXPECT_EQ(opt::magnitude_error("-material_E", 1e-300),
            "-material_E 1e-300 must be a positive number in [1e-150, 1e+150]");
  EXPECT_NE(opt::magnitude_error("-material_rho", 0), "");
  EXPECT_NE(opt::magnitude_error("-material_rho", -7800), "");
  EXPECT_NE(opt::magnitude_error("-material_rho", std::numeric_limits<double>::quiet_NaN()), "");
}

namespace {

// An option block with an integer, a real (under a prefix) and a real that accepts inf.
PetscErrorCode read_numbers(PetscInt* n, double* x, double* y) {
  PetscOptionsBegin(PETSC_COMM_WORLD, "t1_", "test numbers", "");
  PetscCall(MorseOptionsInt("-n", "An integer", "", *n, n, nullptr));
  PetscCall(MorseOptionsReal("-x", "A finite real", "", *x, x, nullptr));
  PetscCall(MorseOptionsRealNonFinite("-y", "A real, inf allowed", "", *y, y, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

}  // namespace

// The wrappers check the text given under the block's prefix before PETSc reads it, and throw a
// morse::Error naming the option (every rank alike: every rank reads the same options).
TEST(Options, WrappersRefuseBadNumbersBeforePetscReadsThem) {
  PetscInt n = 1;
  double x = 0, y = 0;
  {
    GivenOptions given({{"-t1_n", "42"}, {"-t1_x", "2.5"}, {"-t1_y", "inf"}});
    ASSERT_EQ(read_numbers(&n, &x, &y), 0);
    EXPECT_EQ(n, 42);
    EXPECT_EQ(x, 2.5);
    EXPECT_TRUE(std::isinf(y));
  }
  auto error = [&](const char* name, const char* value) {
    GivenOptions given({{name, value}});
    try {
      read_numbers(&n, &x, &y);
    } catch (const morse::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("-t1_n", "5abc"), "-t1_n 5abc: expected an integer");
  EXPECT_EQ(error("-t1_n", "99999999999999999999"),
            "-t1_n 99999999999999999999: out of the integer range [-2147483648, 2147483647]");
  EXPECT_EQ(error("-t1_x", "nan"), "-t1_x nan: expected a finite number");
  EXPECT_EQ(error("-t1_y", "nan"), "");
  EXPECT_EQ(error("-n", "5abc"), "");  // not under the prefix: not read
}
