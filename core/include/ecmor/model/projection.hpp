#pragma once
/// \file projection.hpp
/// Petrov-Galerkin projection (seed Eqs. 2 and 4) and orthogonalisation with deflation.

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// Mr = W' M V, Dr = W' D V, Kr = W' K V, Br = W' B, Cr = C V, Cvr = Cv V (seed Eq. 4).
/// \throws InputError if V, W are not N x n with the same n.
ECMOR_API ReducedSecondOrderModel project(const SecondOrderModel& model, const Matrix& V,
                                          const Matrix& W);
/// Er = W' E V, Ar = W' A V, Br = W' B, Cr = C V (seed Eq. 2).
ECMOR_API ReducedDescriptorModel project(const DescriptorModel& model, const Matrix& V,
                                         const Matrix& W);
/// Dispatch on the model kind; the reduced model has the same kind.
ECMOR_API ReducedModel project(const Model& model, const Matrix& V, const Matrix& W);

/// Inner product for orthogonalisation: Euclidean x'y, or x' G y with G symmetric positive
/// definite.
struct InnerProduct {
  const SparseMatrix* G = nullptr;  ///< nullptr: Euclidean
};

/// Appends the columns of X to the orthonormal basis Q (Q'GQ = I), one column at a time, by
/// classical Gram-Schmidt with one reorthogonalisation ("twice is enough", DGKS). A column whose
/// norm after orthogonalisation falls below deflation_tol times its original norm is dropped
/// (deflated). Returns the number of columns appended.
ECMOR_API Index orthonormalize_append(Matrix& Q, const Matrix& X, const InnerProduct& ip = {},
                                      double deflation_tol = 1e-10);

/// Loss of orthogonality ||Q'GQ - I||_max (0 for an empty Q).
ECMOR_API double orthogonality_loss(const Matrix& Q, const InnerProduct& ip = {});

}  // namespace ecmor
