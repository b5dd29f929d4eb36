// app/cmd_select.cpp: `morse select`, the ranking of the fixed-interface modes by one or more
// methods, their truncated superelements checked against the full model (MAC; select::verify),
// and the superelement of one method written to /rom.
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/handle.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/select/select.hpp"

namespace morse::app::detail {

namespace {

// Options prefixes of the eigen solvers of the full-model check and of the IMR modes.
const char* const kFomPrefix = "select_fom_";
const char* const kImrPrefix = "select_imr_";

std::string hz_of(double lambda) { return cat(hz(lambda)); }

}  // namespace

void run_select(MPI_Comm comm) {
  io::ModelInput o;
  MORSE_CALL(o.set_from_options(comm, "select.h5"));
  cb::CBSettings cs;
  MORSE_CALL(cs.set_from_options(comm));
  ReduceOptions r;
  MORSE_CALL(get_reduce_options(comm, &r));
  select::Settings so;
  MORSE_CALL(so.set_from_options(comm));
  if (help_requested()) return;
  for (const std::string& p : {cs.prefix, std::string(kFomPrefix), std::string(kImrPrefix)})
    options::add_prefix(p, options::Solver::Eigen);
  check_options(comm, true);
  MORSE_CHECK(!cs.boundary_set.empty(), "no boundary set given: use -boundary SET");
  MORSE_CHECK(!so.from.empty() || cs.n_fixed >= 0 || cs.fmax_hz > 0,
              "give the candidate modes: -cb_num_fixed_modes N or -cb_fmax HZ (or -select_from FILE.h5)");
  MORSE_CHECK(so.from.empty() || (cs.n_fixed < 0 && cs.fmax_hz < 0),
              "-select_from reads the candidate modes from its file: drop -cb_num_fixed_modes / -cb_fmax");
  MORSE_CHECK(!(cs.n_fixed >= 0 && cs.fmax_hz > 0), "give only one of -cb_num_fixed_modes and -cb_fmax");
  MORSE_CHECK(so.error.empty(), so.error);
  MORSE_CHECK(!cs.keep_basis, "-cb_write_basis is a reduce option: select writes the selected superelement only");
  MORSE_CHECK(!r.xdmf_set,
              "-cb_xdmf is a reduce option (the mode shapes of -cb_write_basis): select writes no mode "
              "shapes");
  auto inputs = o.inputs();
  inputs.push_back({"-select_from", so.from});
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, inputs);

  Model md = build_model(comm, o);
  MORSE_CHECK(!(!md.mesh && !so.from.empty()),
              "-select_from reads nodal mode shapes of a mesh: not available with -matrices_K/-matrices_M");
  MORSE_CHECK(!(md.C && cs.damping > 0),
              "give either -matrices_C (projected on the selected superelement) or "
              "-cb_damping (modal damping of the fixed-interface modes), not both");
  cs.keep_basis = true;
  auto res = so.from.empty() ? cb::craig_bampton(md, cs) : cb::load_basis(md, so.from, cs.boundary_set, cs.damping);
  MORSE_CHECK(res.n_phi > 0, "no candidate fixed-interface mode to select from");
  if (md.C) res.C = cb::project_symmetric(comm, md.C.get(), res.T.get());  // T^T C T, restricted below
  const PetscInt nb = res.n_b, nr = res.n(), nphi = res.n_phi;
  double f_an = so.verify.fmax_analysis_hz > 0 ? so.verify.fmax_analysis_hz
                : cs.fmax_hz > 0               ? 0.5 * cs.fmax_hz
                                               : 0.5 * std::sqrt(res.fixed_omega2.back()) / kTwoPi;

  select::VerifySettings& vs = so.verify;
  vs.fmax_analysis_hz = f_an;
  auto w = cb::sign_reference(md);
  const auto vr = select::verify(comm, md.K.get(), md.M.get(), res, w.get(), vs);
  check_options(comm, false);
  const auto& results = vr.methods;
  const PetscInt n_fom = static_cast<PetscInt>(vr.fom_omega2.size()), cb_in_band = vr.cb_in_band;
  print0(comm,
         "\nmorse select: %d candidate fixed-interface modes (%s .. %s Hz), %d boundary DOFs; analysis band "
         "%.6g Hz: %d full-model modes\n",
         (int)nphi, hz_of(res.fixed_omega2.front()).c_str(), hz_of(res.fixed_omega2.back()).c_str(), (int)nb, f_an,
         (int)n_fom);
  print0(comm, "  all candidates (plain Craig-Bampton): %d superelement modes in band\n", (int)cb_in_band);
  if (!vr.checked) {
    print0(comm, "  not checked against the full model (-select_check false): no MAC\n");
    print0(comm, "\n  %-10s %6s %10s %14s\n", "method", "N", "retained%", "SE modes<fan");
    for (const auto& mr : results)
      print0(comm, "  %-10s %6d %10.2f %14d\n", mr.name.c_str(), (int)mr.sel.selected.size(), 100 * mr.sel.retained,
             (int)mr.in_band);
  } else {
    print0(comm, "\n  %-10s %6s %10s %14s %12s %14s %14s\n", "method", "N", "retained%", "SE modes<fan", "MAC>thr",
           "subspace MAC", "worst df [%]");
    for (const auto& mr : results)
      print0(comm, "  %-10s %6d %10.2f %14d %7d/%-4d %9d/%-4d %14.4f\n", mr.name.c_str(), (int)mr.sel.selected.size(),
             100 * mr.sel.retained, (int)mr.in_band, (int)mr.matches, (int)n_fom, (int)mr.subspace_matches, (int)n_fom,
             100 * mr.worst_err);
  }

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "select", md.units);
  write_model(out, md);
  io::write_fixed_interface(out, res.fixed_omega2);
  select::write_selection(out, vr, vs.mac_threshold, md.mass);
  for (const auto& mr : results)
    if (mr.name == so.rom_method) {
      auto C = select::restrict_operator(res.C, nb, nr, mr.sel.selected);
      auto se = rom_superelement(res, mr.M, mr.K, cs.damping > 0 || md.C ? &C : nullptr, mr.rom_f, cs.damping);
      se.selected_modes.assign(mr.sel.selected.begin(), mr.sel.selected.end());
      se.selection_method = mr.name;
      io::write_superelement(out, se);
    }
  out.attribute("/cb", "boundary_set", cs.boundary_set);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
