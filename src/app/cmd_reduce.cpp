// app/cmd_reduce.cpp: `morse reduce`, the Craig-Bampton superelement of a model (/rom), with
// its fixed-interface frequencies and optionally the basis (Psi, Phi).
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/io/matrix_model.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::app::detail {

void run_reduce(MPI_Comm comm) {
  io::ModelInput o;
  MORSE_CALL(o.set_from_options(comm, "superelement.h5"));
  cb::CBSettings cs;
  MORSE_CALL(cs.set_from_options(comm));
  ReduceOptions r;
  MORSE_CALL(get_reduce_options(comm, &r));
  if (help_requested()) return;
  options::add_prefix(cs.prefix, options::Solver::Eigen);
  check_options(comm, true);
  MORSE_CHECK(!cs.boundary_set.empty(), "no boundary set given: use -boundary SET");
  MORSE_CHECK(cs.n_fixed >= 0 || cs.fmax_hz > 0, "give -cb_num_fixed_modes N or -cb_fmax HZ");
  MORSE_CHECK(!(cs.n_fixed >= 0 && cs.fmax_hz > 0), "give only one of -cb_num_fixed_modes and -cb_fmax");
  MORSE_CHECK(cs.damping >= 0 && cs.damping < 1, "-cb_damping must be in [0, 1) (got ", cs.damping, ")");
  MORSE_CHECK(!(r.xdmf_set && r.xdmf && !cs.keep_basis),
              "-cb_xdmf writes the mode shapes of -cb_write_basis: add -cb_write_basis");
  MORSE_CHECK(r.write_format == "mtx" || r.write_format == "petsc", "-matrices_write_format ", r.write_format,
              ": expected mtx or petsc");
  std::vector<files::Named> outputs{{"-out", o.out}};
  if (!r.write_matrices.empty())
    for (const auto& f : io::model_matrix_files(r.write_matrices, r.write_format))
      outputs.push_back({"-matrices_write", f});
  const auto output_lock = files::prepare_outputs(comm, outputs, o.inputs());
  Model md = build_model(comm, o);
  MORSE_CHECK(!(!md.mesh && cs.keep_basis),
              "-cb_write_basis writes nodal mode shapes of a mesh: not available with -matrices_K/-matrices_M");
  MORSE_CHECK(!(md.C && cs.damping > 0),
              "give either -matrices_C (projected on the superelement) or -cb_damping "
              "(modal damping of the fixed-interface modes), not both");
  MORSE_CHECK(r.write_matrices.empty() || md.mesh.has_value(), "-matrices_write writes the matrices of a mesh model");
  if (!r.write_matrices.empty()) {
    StageTimer t(comm, "WriteMatrices");
    io::write_model_matrices(comm, md, r.write_matrices, r.write_format);
    const std::string ext = r.write_format == "mtx" ? ".mtx" : ".petsc";
    print0(comm, "morse: wrote %s_K%s, %s_M%s and %s_dofmap.txt\n", r.write_matrices.c_str(), ext.c_str(),
           r.write_matrices.c_str(), ext.c_str(), r.write_matrices.c_str());
  }
  const bool write_basis = cs.keep_basis;
  cs.keep_basis = cs.keep_basis || md.C;
  auto res = cb::craig_bampton(md, cs);
  if (md.C) res.C = cb::project_symmetric(comm, md.C.get(), res.T.get());
  check_options(comm, false);

  const int n = static_cast<int>(res.n());
  std::vector<double> rom_f;
  {
    StageTimer t(comm, "ReducedEigen");
    rom_f = hz(eigen::dense_eigenvalues(n, res.K, res.M));
  }
  const std::vector<double> fi_hz = hz(res.fixed_omega2);
  print0(comm, "morse: Craig-Bampton superelement: %d boundary DOFs (%zu nodes) + %d fixed-interface modes = %d\n",
         (int)res.n_b, res.boundary_node_ids.size(), (int)res.n_phi, n);
  print0(comm, "morse: K_ii factored once%s (%.3f s)\n",
         res.factor_reused ? ", shared by the eigen solver and the constraint modes" : "", res.factor_seconds);
  print0(comm, "\n  %-6s %20s %20s\n", "mode", "fixed-interface [Hz]", "superelement [Hz]");
  const std::size_t rows = std::min<std::size_t>(std::max(fi_hz.size(), rom_f.size()), 20);
  for (std::size_t i = 0; i < rows; ++i)
    print0(comm, "  %-6zu %20s %20s\n", i + 1, i < fi_hz.size() ? cat(fi_hz[i]).c_str() : "",
           i < rom_f.size() ? cat(rom_f[i]).c_str() : "");

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "reduce", md.units);
  io::write_model(out, md);
  io::write_fixed_interface(out, res.fixed_omega2);
  io::write_superelement(
      out, rom_superelement(res, res.M, res.K, cs.damping > 0 || md.C ? &res.C : nullptr, rom_f, cs.damping));
  out.attribute("/cb", "boundary_set", cs.boundary_set);
  std::vector<io::XdmfField> fields;
  if (write_basis) {
    io::write_modes_dataset(out, "/cb/constraint_modes", md, res.T.get(), 0, res.n_b);
    io::write_modes_dataset(out, "/cb/fixed_interface/mode_shapes", md, res.T.get(), res.n_b, res.n_phi);
    out.attribute("/cb/constraint_modes", "description", "Psi: [boundary DOF][node][x,y,z]");
    out.attribute("/cb/fixed_interface/mode_shapes", "description", "Phi: [mode][node][x,y,z], M_ii-normalized");
    fields = {{"/cb/constraint_modes", "psi", (int)res.n_b},
              {"/cb/fixed_interface/mode_shapes", "phi", (int)res.n_phi}};
  }
  out.commit();
  if (r.xdmf && write_basis) write_xdmf_collective(comm, o.out, mesh::gather_to_rank0(*md.mesh), fields);
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
