// dyn/static_file.cpp: the file of a static solution (/static of `morse static`; dyn/dyn.hpp,
// docs/hdf5-schema.md). It is read back as a nodal field (io::read_nodal_field, -fom_initial).
#include <cstdint>
#include <string>
#include <vector>

#include "morse/dyn/dyn.hpp"
#include "morse/io/h5.hpp"

namespace morse::dyn {

void write_static(io::H5Output& out, const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const StaticResult& res,
                  const std::vector<SetProbe>& probes, const StaticSettings& s) {
  auto nodal = io::gather_nodal(lm, dofs, res.u.get());
  out.write("/static/u", nodal, {1, static_cast<hsize_t>(lm.n_global_nodes), 3});
  out.attribute("/static/u", "description", "[1][node][x,y,z] displacement [m], nodes as /mesh/node_ids");
  for (const auto& p : probes) {
    auto u = p.sample(res.u.get());
    out.write("/static/sets/" + p.name() + "/node_ids", p.node_ids());
    out.write("/static/sets/" + p.name() + "/u", u, {static_cast<hsize_t>(p.node_ids().size()), 3});
  }
  std::vector<double> lambda, residual;
  std::vector<std::int64_t> iterations, converged;
  for (const auto& h : res.history) {
    lambda.push_back(h.lambda);
    residual.push_back(h.residual);
    iterations.push_back(h.newton_iterations);
    converged.push_back(h.converged);
  }
  out.write("/static/history/load_factor", lambda);
  out.write("/static/history/newton_iterations", iterations);
  out.write("/static/history/residual", residual);
  out.write("/static/history/converged", converged);
  out.attribute_int("/static", "linear", s.linear ? 1 : 0);
  out.attribute("/static", "time", s.time);
  out.attribute("/static", "load_factor", s.load_factor);
  out.attribute("/static", "load_norm", res.load_norm);
}

}  // namespace morse::dyn
