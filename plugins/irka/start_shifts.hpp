// start_shifts.hpp: IRKA's starting data: band, modal (dominant poles of the full model) and
// balanced shifts, and the completion of a smaller order's final data for a warm start.
#pragma once

#include <optional>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/gramians/balancing.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/model/band.hpp"
#include "ecmor/model/model.hpp"
#include "interpolation.hpp"

namespace ecmor::irka {

/// What the starting data read of the model and of the reducer's settings.
struct StartSetting {
  const Model* model = nullptr;
  FirstOrderView* view = nullptr;
  Band band;
  bool real_poles = false;      // certified real poles (E SPD, A symmetric): real shifts
  bool one_sided = false;       // W = V: a warm start completes with real shifts
  double damping = 0.0;         // zeta of the starting shifts omega (zeta + i)
  Index dense_check_limit = 0;  // balanced shifts need dense Gramians up to this state size
};

/// Band-based starting shifts: floor(r/2) conjugate pairs omega (zeta + i) at log-spaced
/// frequencies of the band, one real shift at the band's geometric centre when r is odd; for a
/// model with certified real poles, r real shifts 2 pi f at log-spaced band frequencies.
/// Restart a > 0 moves the frequencies by a fraction of their spacing and damps them more.
Interpolation band_shifts(const StartSetting& s, Index r, Index attempt);

/// The shifts with the same direction for every shift: the normalised vector of ones.
Interpolation with_uniform_directions(const StartSetting& s, const std::vector<Complex>& shifts);

/// Mirror images of the poles (and residue directions) of the dense square-root balanced
/// truncation of order r (`initial_shifts: balanced`, models of at most dense_check_limit
/// first-order states), by the core's DenseBalancing (gramians/balancing.hpp).
/// `balancing` caches the dense balancing across orders (every order's truncation is a prefix of
/// the same SVD). \throws ConfigError above dense_check_limit.
Interpolation balanced_shifts(const StartSetting& s, std::optional<DenseBalancing>& balancing,
                              Index r);

/// Mirror images of approximate poles of the full model near the band (`initial_shifts: modal`).
/// Second order (symmetric K, M SPD): the floor(r/2) undamped modes K phi = w^2 M phi nearest
/// the band's geometric centre (shift-invert ARPACK, M-normalised phi), each giving the pole
/// pair -a +- i sqrt(w^2 - a^2) with a = phi' D phi / 2 (modal damping), directions B' phi and
/// (C + s Cv) phi; a real shift at the centre when r is odd. Descriptor: the r eigenvalues of
/// (A, E) nearest -2 pi f_centre (general shift-invert ARPACK), uniform directions.
Interpolation modal_shifts(const StartSetting& s, Index r);

/// A warm start from a smaller order's final data `previous`: its shifts and directions,
/// completed to r by shifts in the widest gaps (in log f) of its frequencies (real ones for a
/// one-sided projection) with uniform directions.
Interpolation completed_shifts(const StartSetting& s, const Interpolation& previous, Index r);

}  // namespace ecmor::irka
