#include "ecmor/response/reduced_response.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "linalg/dense_lapack.hpp"
#include "model/first_order_realisation.hpp"

namespace ecmor {
namespace {

// Forming Mr^-1 [Kr Dr] loses about log10(1/rcond) digits: accept at most 8 of 16, far below any
// tolerance a user sets; worse-conditioned mass matrices take the dense LU per frequency.
constexpr double kMinRcond = 1e-8;

// Solves X = A^-1 B with a pivoted LU if A is well conditioned; returns false otherwise.
bool solve_if_well_conditioned(const Matrix& A, const Matrix& B, Matrix& X, double min_rcond) {
  if (A.rows() == 0) return false;
  Eigen::PartialPivLU<Matrix> lu(A);
  const double rcond = lu.rcond();
  if (!(rcond > min_rcond)) return false;
  X = lu.solve(B);
  return X.allFinite();
}

std::string dims(const Matrix& A) {
  return std::to_string(A.rows()) + " x " + std::to_string(A.cols());
}

// The shapes the evaluation indexes (a mismatch would read out of bounds). Values are not checked:
// a reduced model with NaN (a reducer's breakdown) evaluates to non-finite responses or a
// NumericalError per frequency, which the band error reports as such.
template <class Sys>
void check_shapes(const Sys& sys) {
  const std::string origin = "ReducedResponse: reduced model: ";
  const bool second = std::is_same_v<Sys, ReducedSecondOrderModel>;
  const char* ref = second ? "K" : "A";
  const Index n = sys.size();
  auto square = [&](const Matrix& A, const char* name) {
    if (A.rows() != n || A.cols() != n)
      throw InputError(origin + name + " is " + dims(A) + ": must be N x N = " + std::to_string(n) +
                       " x " + std::to_string(n) + " (the size of " + ref + ")");
  };
  auto outputs = [&](const Matrix& C, const char* name) {
    if (C.cols() != n)
      throw InputError(origin + name + " has " + std::to_string(C.cols()) +
                       " columns: must equal N = " + std::to_string(n) + " (the size of " + ref +
                       ")");
  };
  if constexpr (std::is_same_v<Sys, ReducedSecondOrderModel>) {
    square(sys.K, "K");
    square(sys.M, "M");
    square(sys.D, "D");
    if (sys.has_velocity_output()) {
      outputs(sys.Cv, "Cv");
      if (sys.Cv.rows() != sys.C.rows())
        throw InputError(origin + "Cv has " + std::to_string(sys.Cv.rows()) +
                         " rows: must equal the rows of C = " + std::to_string(sys.C.rows()) +
                         " (outputs)");
    }
  } else {
    square(sys.A, "A");
    square(sys.E, "E");
  }
  if (sys.B.rows() != n)
    throw InputError(origin + "B has " + std::to_string(sys.B.rows()) +
                     " rows: must equal N = " + std::to_string(n) + " (the size of " + ref + ")");
  outputs(sys.C, "C");
}

}  // namespace

namespace detail {

std::optional<FirstOrderRealisation> first_order_realisation(const ReducedModel& model,
                                                             double min_rcond) {
  FirstOrderRealisation out;
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&model)) {
    const Index n = so->size();
    Matrix MinvKD, MinvB;
    Matrix KD(n, 2 * n);
    KD << so->K, so->D;
    if (!solve_if_well_conditioned(so->M, KD, MinvKD, min_rcond) ||
        !solve_if_well_conditioned(so->M, so->B, MinvB, min_rcond))
      return std::nullopt;
    out.F = Matrix::Zero(2 * n, 2 * n);
    out.F.topRightCorner(n, n).setIdentity();
    out.F.bottomRows(n) = -MinvKD;
    out.G = Matrix::Zero(2 * n, so->inputs());
    out.G.bottomRows(n) = MinvB;
    out.L = Matrix::Zero(so->outputs(), 2 * n);
    out.L.leftCols(n) = so->C;
    if (so->has_velocity_output()) out.L.rightCols(n) = so->Cv;
  } else {
    const auto& ds = std::get<ReducedDescriptorModel>(model);
    Matrix AB(ds.size(), ds.size() + ds.inputs());
    AB << ds.A, ds.B;
    Matrix X;
    if (!solve_if_well_conditioned(ds.E, AB, X, min_rcond)) return std::nullopt;
    out.F = X.leftCols(ds.size());
    out.G = X.rightCols(ds.inputs());
    out.L = ds.C;
  }
  return out;
}

}  // namespace detail

ReducedResponse::ReducedResponse(const ReducedModel& model) : m_model(model) {
  std::visit([](const auto& sys) { check_shapes(sys); }, model);
  std::optional<detail::FirstOrderRealisation> realisation =
      detail::first_order_realisation(model, kMinRcond);
  if (!realisation || realisation->F.rows() == 0) return;
  Matrix F = std::move(realisation->F), G = std::move(realisation->G),
         L = std::move(realisation->L);
  // Q applied as its Householder reflectors, never formed: forming it cost a quarter of the
  // setup at n = 328 (7 ms of 28), applying it to the few columns of G and rows of L 0.5 ms.
  if (!detail::hessenberg_form(F, G, L)) return;
  Matrix H = std::move(F);
  Matrix QG = std::move(G);
  Matrix LQ = std::move(L);
  if (LQ.rows() < QG.cols()) {
    // Fewer outputs than inputs: evaluate Hr' = G' Q (s I - H')^-1 Q' L' instead, p right-hand
    // sides instead of m. H' is lower Hessenberg; reversing the order of the states (J H' J, J
    // the exchange matrix) makes it upper Hessenberg again, and J J = I leaves Hr' unchanged.
    m_transposed = true;
    H = H.transpose().reverse().eval();
    QG.swap(LQ);
    QG.transposeInPlace();
    LQ.transposeInPlace();
    QG = QG.colwise().reverse().eval();
    LQ = LQ.rowwise().reverse().eval();
  }
  m_minus_H = -H;
  m_G = std::move(QG);
  m_L = std::move(LQ);
  m_scale = m_minus_H.size() > 0 ? m_minus_H.cwiseAbs().maxCoeff() : 0.0;
  m_hessenberg = m_minus_H.allFinite() && m_G.allFinite() && m_L.allFinite();
  if (m_hessenberg) self_check();
}

void ReducedResponse::self_check() {
  // The realisation F = M_r^-1 [K_r D_r] (E_r^-1 A_r) can lose digits that P_r(s) keeps, and the
  // rcond guard above does not see it: on lf10 (M's eigenvalues 3e-11..7e-5) rcond(M_r) = 1.7e-7
  // passed it, and Hr lost 5 digits at every frequency (relative difference 4.5e-5 against the
  // dense LU, whose own rounding there is below 1e-6). Such a loss is the same at all
  // frequencies, so one comparison at a frequency inside the model's spectrum finds it: there the
  // dense LU (O(r^3), about a tenth of the Hessenberg reduction) is the reference, and a
  // difference above 1e-8 sends every evaluation to the dense path.
  double w0 = 1.0;
  if (const auto* so = std::get_if<ReducedSecondOrderModel>(&m_model)) {
    const double m = so->M.diagonal().cwiseAbs().sum(), k = so->K.diagonal().cwiseAbs().sum();
    if (m > 0.0 && k > 0.0) w0 = std::sqrt(k / m);
  } else {
    const auto& ds = std::get<ReducedDescriptorModel>(m_model);
    const double e = ds.E.norm(), a = ds.A.norm();
    if (e > 0.0 && a > 0.0) w0 = a / e;
  }
  if (!std::isfinite(w0) || !(w0 > 0.0)) w0 = 1.0;
  const Complex s0(0.0, w0);
  try {
    const ComplexMatrix fast = (*this)(s0);
    const ComplexMatrix dense = transfer_function(m_model, s0);
    const double scale = dense.norm();
    if (scale > 0.0 && !((fast - dense).norm() <= 1e-8 * scale)) m_hessenberg = false;
  } catch (const NumericalError&) {
    // s0 is (numerically) a pole: no verdict from here; keep the Hessenberg path.
  }
}

namespace {

// Per-thread scratch space of the Hessenberg path (O(n m) doubles), reused across calls and
// evaluators. Complex quantities are held as separate real and imaginary parts: with interleaved
// std::complex, GCC spills the complex multiplier of each axpy to the stack on every iteration (a
// failed store forwarding per element, measured 2x slower than the row-wise original), while
// split parts give plain real axpys that vectorise.
struct Workspace {
  Vector ar, ai;              // column k of (s I - H) Z, rows 0..k
  Vector cr, ci;              // column k - 1 of (s I - H) Z, rows 0..k - 1
  Matrix yr, yi;              // right-hand sides G, becoming R^-1 G from the bottom up (n x m)
  Vector lar, lai, lcr, lci;  // columns k and k - 1 of L Z
};

/// The thread's workspace, sized for G (n x m) and L (p x n): Y = G, column n - 1 of L Z = L's.
Workspace& workspace(const Matrix& G, const Matrix& L) {
  thread_local Workspace w;
  const Index n = G.rows(), m = G.cols(), p = L.rows();
  w.ar.resize(n);
  w.ai.resize(n);
  w.cr.resize(n);
  w.ci.resize(n);
  w.yr = G;
  w.yi.setZero(n, m);
  w.lar = L.col(n - 1);
  w.lai.setZero(p);
  w.lcr.resize(p);
  w.lci.resize(p);
  return w;
}

/// out_r + i out_i, transposed for a model evaluated through its transpose.
ComplexMatrix assemble(const Matrix& out_r, const Matrix& out_i, bool transposed) {
  ComplexMatrix out(transposed ? out_r.cols() : out_r.rows(),
                    transposed ? out_r.rows() : out_r.cols());
  if (transposed) {
    out.real() = out_r.transpose();
    out.imag() = out_i.transpose();
  } else {
    out.real() = out_r;
    out.imag() = out_i;
  }
  return out;
}

// |re| + |im|: the modulus up to a factor sqrt(2), without hypot's cost (LAPACK's pivot measure,
// cabs1, for the same reason).
inline double abs1(double re, double im) { return std::abs(re) + std::abs(im); }

// q = a / b for b != 0, scaled so that |b|^2 neither overflows nor underflows.
inline void divide(double ar, double ai, double br, double bi, double& qr, double& qi) {
  const double t = 1.0 / abs1(br, bi);
  br *= t;
  bi *= t;
  const double d = t / (br * br + bi * bi);  // |b'|^2 in [1/2, 1]
  qr = (ar * br + ai * bi) * d;
  qi = (ai * br - ar * bi) * d;
}

[[noreturn]] void throw_pole(Complex s) {
  std::ostringstream os;
  os << "reduced model: s = " << s.real() << (s.imag() < 0 ? "-" : "+") << std::abs(s.imag())
     << "i is (numerically) a pole";
  throw NumericalError(os.str());
}

[[noreturn]] void throw_not_finite(Complex s) {
  std::ostringstream os;
  os << "reduced response: s = " << s.real() << (std::signbit(s.imag()) ? "-" : "+")
     << std::abs(s.imag()) << "i: must be finite";
  throw NumericalError(os.str());
}

}  // namespace

ComplexMatrix ReducedResponse::operator()(Complex s) const {
  if (!std::isfinite(s.real()) || !std::isfinite(s.imag())) throw_not_finite(s);
  if (!m_hessenberg) return transfer_function(m_model, s);
  const Index n = m_minus_H.rows(), m = m_G.cols(), p = m_L.rows();
  const double sr = s.real(), si = s.imag();
  const double scale = m_scale + std::abs(s);  // bounds max |T_ij| without a pass over T
  const double tiny = scale * static_cast<double>(n) * std::numeric_limits<double>::epsilon();

  // T = s I - H is upper Hessenberg. Its subdiagonal is eliminated by column operations, from the
  // last column to the first: T Z = R upper triangular, Z a product of elementary
  // transformations, each with partial pivoting between columns k - 1 and k (the column
  // counterpart of Laub's row pivoting: growth bounded by n, backward stable). Then
  // Hr = L T^-1 G = (L Z) R^-1 G. Column k of R is final once step k is done, which is exactly
  // when the column-oriented back substitution R Y = G needs it, and so is column k of L Z: the
  // elimination, the substitution and the product L Z Y run in one sweep that keeps two columns,
  // O(n m) memory in all. Why columns, not rows: the matrices are column-major, so every update
  // runs over contiguous memory (Laub's row operations stride by n), and -H is only read, once.
  Workspace& w = workspace(m_G, m_L);
  double* ar = w.ar.data();
  double* ai = w.ai.data();
  double* cr = w.cr.data();
  double* ci = w.ci.data();
  Vector* la_r = &w.lar;
  Vector* la_i = &w.lai;
  Vector* lc_r = &w.lcr;
  Vector* lc_i = &w.lci;
  Matrix out_r = Matrix::Zero(p, m), out_i = Matrix::Zero(p, m);

  {
    const double* b = m_minus_H.col(n - 1).data();
    for (Index i = 0; i < n; ++i) {
      ar[i] = b[i];
      ai[i] = 0.0;
    }
    ar[n - 1] += sr;
    ai[n - 1] += si;
  }
  for (Index k = n - 1; k >= 0; --k) {
    if (k > 0) {
      // a: column k of T Z so far (rows 0..k; rows below are zero); c: column k - 1 of R (rows
      // 0..k - 1); b: column k - 1 of -H (rows 0..k), column k - 1 of T but for s on the diagonal.
      const double* __restrict b = m_minus_H.col(k - 1).data();
      const double bk = b[k];  // the subdiagonal entry to eliminate (real: T - s I is real)
      const double akr = ar[k], aki = ai[k];
      const auto Lb = m_L.col(k - 1);
      if (std::abs(bk) > abs1(akr, aki)) {
        // Pivot: exchange columns k - 1 and k, then subtract l times the new column k (old k - 1)
        // from the new column k - 1 (old k).
        const double lr = akr / bk, li = aki / bk;
        double* __restrict xr = ar;
        double* __restrict xi = ai;
        double* __restrict yr = cr;
        double* __restrict yi = ci;
        for (Index i = 0; i < k; ++i) {
          yr[i] = xr[i] - lr * b[i];
          yi[i] = xi[i] - li * b[i];
          xr[i] = b[i];
          xi[i] = 0.0;
        }
        cr[k - 1] -= lr * sr - li * si;  // the diagonal s of the old column k - 1
        ci[k - 1] -= lr * si + li * sr;
        ar[k - 1] += sr;
        ai[k - 1] += si;
        ar[k] = bk;
        ai[k] = 0.0;
        *lc_r = *la_r - lr * Lb;
        *lc_i = *la_i - li * Lb;
        *la_r = Lb;
        la_i->setZero();
      } else {
        // |a_k| >= |b_k|: subtract l = b_k / a_k times column k. b_k = 0 needs no elimination
        // (and a_k = 0 then must not divide: the singularity test below catches it).
        double lr = 0.0, li = 0.0;
        if (bk != 0.0) divide(bk, 0.0, akr, aki, lr, li);
        const double* __restrict xr = ar;
        const double* __restrict xi = ai;
        double* __restrict yr = cr;
        double* __restrict yi = ci;
        for (Index i = 0; i < k; ++i) {
          yr[i] = b[i] - (lr * xr[i] - li * xi[i]);
          yi[i] = -(lr * xi[i] + li * xr[i]);
        }
        cr[k - 1] += sr;
        ci[k - 1] += si;
        *lc_r = Lb - lr * *la_r + li * *la_i;
        *lc_i = -lr * *la_i - li * *la_r;
      }
    }
    // Column k of R (a) and of L Z (la) are final: back substitution step k, and the term of
    // (L Z) Y it completes.
    if (!(abs1(ar[k], ai[k]) > tiny)) throw_pole(s);
    for (Index j = 0; j < m; ++j) {
      double* __restrict yr = w.yr.col(j).data();
      double* __restrict yi = w.yi.col(j).data();
      double qr, qi;
      divide(yr[k], yi[k], ar[k], ai[k], qr, qi);
      const double* __restrict xr = ar;
      const double* __restrict xi = ai;
      for (Index i = 0; i < k; ++i) {
        yr[i] -= qr * xr[i] - qi * xi[i];
        yi[i] -= qr * xi[i] + qi * xr[i];
      }
      out_r.col(j) += qr * *la_r - qi * *la_i;
      out_i.col(j) += qr * *la_i + qi * *la_r;
    }
    std::swap(ar, cr);
    std::swap(ai, ci);
    std::swap(la_r, lc_r);
    std::swap(la_i, lc_i);
  }
  return assemble(out_r, out_i, m_transposed);
}

}  // namespace ecmor
