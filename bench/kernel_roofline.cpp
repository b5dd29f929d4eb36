// bench/kernel_roofline.cpp: the cubic force kernels of the online stage on ONE core, for the
// roofline of bench/kernel_roofline.py (issue 29). Built with morse (build/kernel_roofline).
//
//     build/kernel_roofline [--r 54,79,89] [--lanes 1,4,8,16] [--seconds 0.5] [--reps 5]
//
// For each r: a reduced force that is the gradient of a quartic potential with pseudo-random
// coefficients (the kernels' speed depends on r and the storage, not on the values), its
// CubicKernel (potential layout: `morse simulate` and the sweep's per-lane kernel above r = 56) and
// its CubicKernelBatch in double and in float. For each number of lanes B it times:
//   - lane: CubicKernel::apply once per lane (B = 1 only: it is B times that),
//   - batch: CubicKernelBatch::apply over ceil(B / 4) groups of 4 lanes (B = 1: one group, 1 lane used),
//   - float: the same with float coefficients.
// batch and float run the widest build the processor has (as the sweep does; "isa" in the JSON);
// on an AVX-512 processor, batch-avx2 and float-avx2 also time the AVX2 build.
// Each figure is the median of --reps timings of about --seconds each, the kernels of one r timed
// in turn in every repetition (the machine's drift hits them alike). Prints one JSON object:
// {"r": [{"r", "coefficients", "bytes_double", "flops_per_lane", "runs": [{"kernel", "lanes",
// "passes_per_s", "lane_steps_per_s", "gflops", "gbs", "samples"}]}]}; flops are the useful ones
// (4 per coefficient and lane, plus 2 r^2 for P3), bytes those of the coefficients read per pass.
#include <petscsys.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"

namespace {

using Clock = std::chrono::steady_clock;

std::vector<std::size_t> parse_list(const char* s) {
  std::vector<std::size_t> v;
  for (const char* p = s; *p;) {
    char* end = nullptr;
    v.push_back(std::strtoul(p, &end, 10));
    p = *end == ',' ? end + 1 : end;
    if (end == p && *p) break;
  }
  return v;
}

// A force that is the gradient of V = sum c3 q_i q_j q_k + sum c4 q_i q_j q_k q_l (sorted tuples,
// coefficients from a fixed linear congruential sequence): A(m, p) = mult(p) c3[sort(i, j, p)] for
// monomial m = (i, j), and alike for B.
morse::nlrom::CubicForce potential_force(std::size_t r) {
  unsigned long long state = 12345;
  auto next = [&]() {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5;
  };
  std::vector<double> c3(r * r * r, 0.0), c4(r * r * r * r, 0.0);  // dense by sorted index, r <= 100
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j)
      for (std::size_t k = j; k < r; ++k) {
        c3[(i * r + j) * r + k] = next();
        for (std::size_t l = k; l < r; ++l) c4[((i * r + j) * r + k) * r + l] = next();
      }
  morse::nlrom::CubicForce g;
  g.r = r;
  g.A.assign(morse::nlrom::n_quadratic(r) * r, 0.0);
  g.B.assign(morse::nlrom::n_cubic(r) * r, 0.0);
  std::size_t m = 0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j, ++m)
      for (std::size_t p = 0; p < r; ++p) {
        std::size_t t[3] = {i, j, p};
        std::sort(t, t + 3);
        g.A[m * r + p] = static_cast<double>(1 + (i == p) + (j == p)) * c3[(t[0] * r + t[1]) * r + t[2]];
      }
  m = 0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j)
      for (std::size_t k = j; k < r; ++k, ++m)
        for (std::size_t p = 0; p < r; ++p) {
          std::size_t t[4] = {i, j, k, p};
          std::sort(t, t + 4);
          g.B[m * r + p] =
              static_cast<double>(1 + (i == p) + (j == p) + (k == p)) * c4[((t[0] * r + t[1]) * r + t[2]) * r + t[3]];
        }
  return g;
}

// Calls per second of each of fs: calibrated to about `seconds` per timing, then reps rounds in
// which every f is timed once in turn (interleaved, so that the machine's drift hits them alike);
// the median of each f's reps.
std::vector<double> rates(const std::vector<std::function<void()>>& fs, double seconds, int reps,
                          std::vector<std::vector<double>>* samples) {
  std::vector<long> n(fs.size(), 1);
  for (std::size_t i = 0; i < fs.size(); ++i) {
    fs[i]();  // warm
    for (;;) {
      const auto t0 = Clock::now();
      for (long k = 0; k < n[i]; ++k) fs[i]();
      const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
      if (dt > 0.05) {
        n[i] = std::max(1L, static_cast<long>(static_cast<double>(n[i]) * seconds / dt));
        break;
      }
      n[i] *= 4;
    }
  }
  samples->assign(fs.size(), {});
  for (int k = 0; k < reps; ++k)
    for (std::size_t i = 0; i < fs.size(); ++i) {
      const auto t0 = Clock::now();
      for (long j = 0; j < n[i]; ++j) fs[i]();
      (*samples)[i].push_back(static_cast<double>(n[i]) / std::chrono::duration<double>(Clock::now() - t0).count());
    }
  std::vector<double> med;
  for (auto s : *samples) {
    std::sort(s.begin(), s.end());
    med.push_back(s.size() % 2 ? s[s.size() / 2] : 0.5 * (s[s.size() / 2 - 1] + s[s.size() / 2]));
  }
  return med;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::size_t> rs = {54, 79, 89}, lanes = {1, 4, 8, 16};
  double seconds = 0.5;
  int reps = 5;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a];
    if (k == "--r")
      rs = parse_list(argv[a + 1]);
    else if (k == "--lanes")
      lanes = parse_list(argv[a + 1]);
    else if (k == "--seconds")
      seconds = std::atof(argv[a + 1]);
    else if (k == "--reps")
      reps = std::atoi(argv[a + 1]);
    else {
      std::fprintf(stderr, "kernel_roofline: unknown option %s\n", k.c_str());
      return 1;
    }
  }
  if (rs.empty() || lanes.empty() || seconds <= 0 || reps < 1) {
    std::fprintf(stderr, "kernel_roofline: bad --r, --lanes, --seconds or --reps\n");
    return 1;
  }
  for (std::size_t r : rs)
    if (r < 1 || r > 100) {
      std::fprintf(stderr, "kernel_roofline: r = %zu outside 1..100\n", r);
      return 1;
    }
  double checksum = 0.0;
  std::printf("{\"r\": [");
  for (std::size_t ir = 0; ir < rs.size(); ++ir) {
    const std::size_t r = rs[ir];
    std::fprintf(stderr, "kernel_roofline: r = %zu: building the coefficients\n", r);
    const auto g = potential_force(r);
    std::vector<double> P3(r * r, 0.0);
    for (std::size_t i = 0; i < r; ++i) P3[i * r + i] = 1.0;
    const morse::sim::CubicKernel lane(g, P3, morse::sim::KernelLayout::Potential);
    const morse::sim::CubicKernelBatch batch(lane), single(lane, true);
    morse::sim::CubicKernelBatch batch2(lane), single2(lane, true);
    const bool both = batch.isa() == morse::sim::KernelIsa::Avx512;
    if (both) batch2.set_isa(morse::sim::KernelIsa::Avx2), single2.set_isa(morse::sim::KernelIsa::Avx2);
    const double coefficients = batch.bytes() / 8.0;
    std::printf(
        "%s{\"r\": %zu, \"coefficients\": %.0f, \"bytes_double\": %.0f, \"flops_per_lane\": %.0f, \"isa\": \"%s\", "
        "\"runs\": [",
        ir ? ", " : "", r, coefficients, batch.bytes(), batch.flops(), morse::sim::kernel_isa_name(batch.isa()));
    bool first = true;
    auto emit = [&](const char* kernel, std::size_t B, double passes, double lanes_per_pass, double bytes,
                    const std::vector<double>& samples) {
      const double ls = passes * lanes_per_pass;
      std::printf(
          "%s{\"kernel\": \"%s\", \"lanes\": %zu, \"passes_per_s\": %.6g, \"lane_steps_per_s\": %.6g, "
          "\"gflops\": %.6g, \"gbs\": %.6g, \"samples\": [",
          first ? "" : ", ", kernel, B, passes, ls, ls * batch.flops() * 1e-9, passes * bytes * 1e-9);
      for (std::size_t k = 0; k < samples.size(); ++k) std::printf("%s%.6g", k ? ", " : "", samples[k]);
      std::printf("]}");
      first = false;
      std::fprintf(stderr, "  r = %zu, %-10s B = %2zu: %9.1f lane-steps/s, %6.2f GFLOP/s, %6.2f GB/s\n", r, kernel, B,
                   ls, ls * batch.flops() * 1e-9, passes * bytes * 1e-9);
    };
    // Every kernel and number of lanes of this r, timed interleaved.
    struct Case {
      const char* kernel;
      std::size_t B;
      double lanes_per_pass, bytes;
    };
    std::vector<Case> cases;
    std::vector<std::function<void()>> fs;
    const std::size_t Bmax = *std::max_element(lanes.begin(), lanes.end()), Lmax = 4 * ((Bmax + 3) / 4);
    std::vector<double> Q(r * Lmax), Y(r * Lmax, 0.0), q(r), y(r);
    for (std::size_t j = 0; j < r; ++j)
      for (std::size_t l = 0; l < Lmax; ++l) Q[j * Lmax + l] = 1e-3 * std::cos(0.7 * static_cast<double>(j) + 0.3 * l);
    for (std::size_t j = 0; j < r; ++j) q[j] = Q[j * Lmax];
    std::vector<std::size_t> groups(Lmax / 4);
    for (std::size_t k = 0; k < groups.size(); ++k) groups[k] = k;
    for (std::size_t B : lanes) {
      const std::size_t ng = (B + 3) / 4;
      if (B == 1) {
        cases.push_back({"lane", 1, 1.0, lane.bytes()});
        fs.push_back([&]() { lane.apply(q.data(), y.data()); });
      }
      cases.push_back({"batch", B, static_cast<double>(B), batch.bytes()});
      fs.push_back([&, ng]() { batch.apply(Lmax, groups.data(), ng, Q.data(), Y.data()); });
      cases.push_back({"float", B, static_cast<double>(B), single.bytes()});
      fs.push_back([&, ng]() { single.apply(Lmax, groups.data(), ng, Q.data(), Y.data()); });
      if (both) {
        cases.push_back({"batch-avx2", B, static_cast<double>(B), batch2.bytes()});
        fs.push_back([&, ng]() { batch2.apply(Lmax, groups.data(), ng, Q.data(), Y.data()); });
        cases.push_back({"float-avx2", B, static_cast<double>(B), single2.bytes()});
        fs.push_back([&, ng]() { single2.apply(Lmax, groups.data(), ng, Q.data(), Y.data()); });
      }
    }
    std::vector<std::vector<double>> samples;
    const auto med = rates(fs, seconds, reps, &samples);
    checksum += y[0] + Y[0];
    for (std::size_t c = 0; c < cases.size(); ++c)
      emit(cases[c].kernel, cases[c].B, med[c], cases[c].lanes_per_pass, cases[c].bytes, samples[c]);
    std::printf("]}");
  }
  double rss_mb = 0.0;  // peak resident memory (VmHWM)
  if (FILE* f = std::fopen("/proc/self/status", "r")) {
    char line[256];
    while (std::fgets(line, sizeof line, f))
      if (std::strncmp(line, "VmHWM:", 6) == 0) rss_mb = std::atof(line + 6) / 1024.0;
    std::fclose(f);
  }
  std::printf("], \"seconds\": %g, \"reps\": %d, \"max_rss_mb\": %.1f, \"checksum\": %.17g}\n", seconds, reps, rss_mb,
              checksum);
  return 0;
}
