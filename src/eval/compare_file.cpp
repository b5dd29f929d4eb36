// eval/compare_file.cpp: /compare written into a simulate file (eval/indicator.hpp,
// docs/hdf5-schema.md).
#include <hdf5.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/eval/indicator.hpp"

namespace morse::eval {

void write_compare(const std::string& file, const eval::Indicator& ind, double tmax, double tsnap,
                   const std::string& fom, const std::string& tip) {
  const std::string tmp = files::temp_path(file);
  std::error_code ec;
  std::filesystem::copy_file(file, tmp, std::filesystem::copy_options::overwrite_existing, ec);
  MORSE_CHECK(!ec, "compare: cannot copy ", file, " to write /compare into it: ", ec.message());
  hid_t f = H5Fopen(tmp.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (f < 0) {
    std::remove(tmp.c_str());
    throw Error(cat("compare: cannot open ", file, " for writing"));
  }
  if (H5Lexists(f, "/compare", H5P_DEFAULT) > 0) H5Ldelete(f, "/compare", H5P_DEFAULT);
  hid_t g = H5Gcreate2(f, "/compare", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  bool ok = g >= 0;
  auto put = [&](const char* name, const double* v, hsize_t n) {
    hid_t sp = H5Screate_simple(1, &n, nullptr);
    hid_t d = H5Dcreate2(g, name, H5T_NATIVE_DOUBLE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ok = ok && d >= 0 && H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) >= 0;
    if (d >= 0) H5Dclose(d);
    H5Sclose(sp);
  };
  auto attr = [&](const char* name, const std::string& v) {
    hid_t t = H5Tcopy(H5T_C_S1);
    H5Tset_size(t, v.size() + 1);
    hid_t sp = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(g, name, t, sp, H5P_DEFAULT, H5P_DEFAULT);
    ok = ok && a >= 0 && H5Awrite(a, t, v.c_str()) >= 0;
    if (a >= 0) H5Aclose(a);
    H5Sclose(sp);
    H5Tclose(t);
  };
  if (ok) {
    const double I = ind.I();
    put("e", ind.e.data(), 4);
    put("weights", ind.w.data(), 4);
    put("I", &I, 1);
    put("t_max", &tmax, 1);
    put("t_snapshot", &tsnap, 1);
    attr("fom", fom);
    attr("tip_set", tip);
    attr("description",
         "seed 003 eq. 43-51: e = (e1 covariance at t_max, e2 energy, e3 tip peak-to-peak, "
         "e4 tip displacement), I = sum w e");
  }
  if (g >= 0) H5Gclose(g);
  H5Fclose(f);
  if (!ok) {
    std::remove(tmp.c_str());
    throw Error(cat("compare: cannot write /compare into ", file));
  }
  files::commit(tmp, file);
}

}  // namespace morse::eval
