// Private to src/nlrom: the modal damping matrix shared by project_model (the whole reduced model)
// and make_massless (the dynamic block of a massless one).
#pragma once

#include <petscsys.h>

#include <vector>

namespace morse::nlrom::detail {

/// C = sum_{m < k} 2 xi w_m (M x_m)(M x_m)^T (n x n, row-major) for the M-normalized modes x_m of
/// (K, M) (n x n, row-major, ascending); the w_m are appended to *omega. Zero if xi or k is 0.
std::vector<double> modal_damping_matrix(std::size_t n, const std::vector<double>& K, const std::vector<double>& M,
                                         double xi, PetscInt k, std::vector<double>* omega);

}  // namespace morse::nlrom::detail
