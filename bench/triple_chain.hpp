#pragma once
/// \file triple_chain.hpp
/// Generator of the triple chain oscillator (Truhar and Veselic; M-M.E.S.S. `triplechain_MSD`), the
/// scalable second-order benchmark used by bench_core and in scaling studies (N up to 1e6).
///
/// Three chains of n1 masses each (m1 = 1, m2 = 2, m3 = 3) joined by springs (k1 = 10, k2 = 20,
/// k3 = 1). The first mass of every chain hangs on a grounding spring of its chain's stiffness, the
/// last mass of every chain is joined by a spring of its chain's stiffness to one extra mass m0 =
/// 10, itself grounded by k0 = 50. With 1-based indices, chain c in {1, 2, 3} holds the masses
/// (c-1) n1 + 1 .. c n1 and m0 is the last coordinate N = 3 n1 + 1:
///
///   M = diag(m1 I, m2 I, m3 I, m0)
///   K = [K1 . . -k1 e_n1; . K2 . -k2 e_n1; . . K3 -k3 e_n1; sym, k1 + k2 + k3 + k0],
///       Kc = kc tridiag(-1, 2, -1) (n1 x n1)
///   D = alpha M + beta K + v (e_1 e_1' + e_n1 e_n1' + e_(2n1+1) e_(2n1+1)')
///   B = ones(N, 1),  C = ones(1, N)
///
/// The three grounded dampers sit at the first and last mass of chain 1 and the first mass of
/// chain 3: that is the (asymmetric-looking) convention of M-M.E.S.S., verified entry by entry
/// against the benchmark models triplechain_{cmess_n301, saak09_n451, mess_n1501}.

#include "ecmor/base/types.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::bench {

/// Largest n1 for which N = 3 n1 + 1 and nnz(K) = 9 n1 + 1 fit the 32-bit indices of SparseMatrix.
constexpr Index kTripleChainMaxN1 = 238609294;  // (2^31 - 1 - 1) / 9

/// The triple chain model with n1 masses per chain (N = 3 n1 + 1), built directly from triplets in
/// O(N) time and memory. All three matrices are symmetric; M and K are positive definite, D is
/// positive definite whenever alpha > 0 or beta > 0.
/// \param n1     masses per chain, 1 <= n1 <= kTripleChainMaxN1
/// \param alpha  Rayleigh mass-proportional damping, finite, >= 0
/// \param beta   Rayleigh stiffness-proportional damping, finite, >= 0
/// \param v      viscosity of the three grounded dampers, finite, >= 0
/// \throws ConfigError naming the parameter, its value and the rule broken (negative damping would
///         make the generated model unstable, so it is refused rather than silently produced).
SecondOrderModel triple_chain(Index n1, double alpha, double beta, double v);

}  // namespace ecmor::bench
