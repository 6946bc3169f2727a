// Procedural density grids for glass bulk scattering (`flare volume make`; docs/volumes.md).
//
// Every grid fills the cylinder x² + y² <= radius², 0 <= z <= thickness of an element's local
// frame (mm; z from the front vertex along the axis). Only voxels lying wholly inside that
// cylinder are active, so no density leaks out of the glass. The voxels are aligned with z = 0 and
// with the x and y axes: voxel (i, j, k) spans [i, i + 1] × [j, j + 1] × [k, k + 1] voxels.
//
// Every value lies in [0, density]; what the kinds represent:
//   haze        weak volume scatter spread through the whole blank (devitrification haze, fine
//               seed or colloidal scatter): smooth fractal value noise with correlation length
//               correlationMm; values in [(1 − variation)·density, density], every voxel active.
//   striae      thin wavy sheets parallel to z (cords and streaks of index inhomogeneity in a
//               pressed or poured blank) of Gaussian cross-section, full width at half maximum
//               featureMm; count sheets, roughly parallel to each other, each running for part of
//               the chord, peak density·[0.5, 1]; 0 elsewhere (values below 1e-3·density dropped).
//   bubbles     count gas bubbles (seeds), spheres of radius featureMm·[0.5, 1.5], centres uniform
//               in the cylinder (a Poisson process conditioned on its count) with every sphere
//               wholly inside it; a voxel's value is density × the fraction of it inside bubbles.
//   inclusions  count stones (unmelted batch, refractory specks): small ellipsoids with random
//               orientation and semi-axes featureMm/2·[0.5, 1]; value = density × volume fraction
//               (give a high density: stones are dense, opaque scatterers).
// Bubble and stone volume fractions are scaled so that each feature's voxels hold its exact
// volume: totals do not depend on the voxel size, and features far smaller than a voxel are kept.
// The grid is deterministic for a given set of options (seed included).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "flare/photons/VolumeGrid.h"

namespace flare {

struct VolumeMakeOptions {
    enum class Kind { Haze, Striae, Bubbles, Inclusions };
    Kind kind = Kind::Haze;
    double radiusMm = 12.0;      // cylinder radius (the element's clear radius)
    double thicknessMm = 6.0;    // along z, from z = 0
    double voxelMm = 0.1;
    std::uint64_t seed = 1;
    double density = 1.0;        // peak relative density: every value lies in [0, density]
    int count = 40;              // bubbles, inclusions; striae: the number of sheets
    double featureMm = 0.15;     // bubble radius / stria width (FWHM) / inclusion size (diameter)
    double correlationMm = 0.0;  // haze: correlation length of the variation; 0 = radiusMm / 4
    double variation = 0.3;      // haze: values in [(1 − variation)·density, density]
    std::string gridName = "density";
};

const char* toString(VolumeMakeOptions::Kind kind);
std::optional<VolumeMakeOptions::Kind> parseVolumeKind(const std::string& name);

// The `flare volume make` options that reproduce `options` (stored as the grid's description).
std::string describe(const VolumeMakeOptions& options);

// Throws std::invalid_argument for options out of range (non-positive sizes, a negative count, a
// voxel too large for the cylinder, more than 2^28 voxels in the cylinder's bounding box).
VolumeGrid makeVolume(const VolumeMakeOptions& options);

}  // namespace flare
