// next_shifts.hpp: IRKA's fixed-point map, from a reduced model's poles and residues to the next
// interpolation data (mirror images of the dominant poles). Also the map from any pole-residue
// form to starting data (balanced, modal and warm starts).
#pragma once

#include <vector>

#include "ecmor/base/types.hpp"
#include "interpolation.hpp"

namespace ecmor::irka {

/// The next shifts: mirror images of the reduced poles (r of the 2r poles of a second-order
/// model, the largest H2 contributions first), poles with Re >= 0 reflected first; directions
/// the residue directions, normalised.
/// \throws NumericalError when fewer than r shifts can be chosen.
Interpolation next_shifts(const PoleResidues& pr, Index r, Index& reflected);

/// |c_i|^2 |b_i|^2 / |Re lambda_i|: the size of pole i's term in the H2 norm.
double h2_weight(const PoleResidues& pr, Index i);

/// r poles of the 2r of a second-order reduced model, closed under conjugation, by decreasing
/// H2 weight |c_i|^2 |b_i|^2 / |Re lambda_i| (the size of the pole's term in the H2 norm).
/// An odd r with no real pole left is completed by the pair's member with Im > 0 turned into
/// the real shift |lambda|; handled by the caller through canonical() (a real shift).
std::vector<Index> dominant(const PoleResidues& pr, Index r);

}  // namespace ecmor::irka
