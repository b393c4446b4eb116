#pragma once
/// \file solid_geometry.hpp
/// The mesh of the solid generator (solid.hpp) as finite-element geometry, for the tests and tools
/// that exchange bodies with other programs (ecmor/interop/fe_geometry.hpp). Apart from solid.hpp,
/// so that the generator itself needs only the core.

#include "ecmor/interop/fe_geometry.hpp"
#include "solid.hpp"

namespace ecmor::bench {

/// The mesh of solid(options) as nodes.csv/dofs.csv data (fe_geometry.hpp), for the mass
/// invariants of the body (docs/multibody.md): every node of the box, clamped ones included, with
/// id 1 + i + (nx + 1)(j + (ny + 1) k) at (i lx/nx, j ly/ny, k lz/nz); the DOF rows of the
/// numbering in solid.hpp's file comment (directions 1..3). The ids do not depend on `clamped`, so
/// the free box is the mass model of the clamped one. \throws ConfigError from options.validate().
FeGeometry solid_geometry(const SolidOptions& options);

}  // namespace ecmor::bench
