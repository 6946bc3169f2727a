#include "VolumeCommand.h"
#include "Output.h"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>

#include <nlohmann/json.hpp>

#include "flare/core/OutputFiles.h"
#include "flare/photons/VolumeGrid.h"
#include "flare/photons/VolumeMake.h"

namespace flare::cli {

namespace {

struct VolumeMakeCommandOptions {
    VolumeMakeOptions make;
    std::string kind;
    std::string output;
    bool countGiven = false;
};

struct VolumeInfoCommandOptions {
    std::string file;
    std::string grid;
    bool json = false;
};

// Without --count: 40 bubbles, 8 stones, 12 striae.
int defaultCount(VolumeMakeOptions::Kind kind) {
    switch (kind) {
        case VolumeMakeOptions::Kind::Inclusions: return 8;
        case VolumeMakeOptions::Kind::Striae: return 12;
        default: return 40;
    }
}

std::string formatNumber(double x) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.6g", x);
    return buffer;
}

nlohmann::json point(const glm::dvec3& p) { return nlohmann::json::array({p.x, p.y, p.z}); }

void printSummary(const VolumeGrid& grid) {
    const auto line = [](const char* key, const std::string& value) { std::printf("%-15s%s\n", key, value.c_str()); };
    const glm::dvec3 lo = grid.boundsMinMm(), hi = grid.boundsMaxMm();
    line("grid", "\"" + grid.name() + "\" (float)");
    if (!grid.description().empty()) line("description", grid.description());
    line("voxel size", formatNumber(grid.voxelSizeMm()) + " mm");
    line("bounds", "x [" + formatNumber(lo.x) + ", " + formatNumber(hi.x) + "]  y [" + formatNumber(lo.y) + ", " +
                       formatNumber(hi.y) + "]  z [" + formatNumber(lo.z) + ", " + formatNumber(hi.z) + "] mm");
    line("values", "min " + formatNumber(grid.minValue()) + "  mean " + formatNumber(grid.meanValue()) + "  max " +
                       formatNumber(grid.maxValue()) + " (majorant)");
    line("active voxels", std::to_string(grid.activeVoxelCount()));
}

void runMake(VolumeMakeCommandOptions& o) {
    const auto kind = parseVolumeKind(o.kind);
    if (!kind) throw CLI::ValidationError("--kind", "unknown kind " + o.kind);  // (IsMember checks this first)
    o.make.kind = *kind;
    if (!o.countGiven) o.make.count = defaultCount(*kind);
    OutputFiles outputs;
    outputs.add(o.output, "-o");
    VolumeGrid grid;
    try {
        grid = makeVolume(o.make);
    } catch (const std::invalid_argument& e) {
        throw CLI::ValidationError("volume make", e.what());
    }
    grid.save(outputs, o.output);
    outputs.commit();
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(o.output, ec);
    std::printf("wrote %s (%s bytes)\n", o.output.c_str(), ec ? "?" : std::to_string(bytes).c_str());
    printSummary(grid);
}

void runInfo(const VolumeInfoCommandOptions& o) {
    const VolumeGrid grid = VolumeGrid::load(o.file, o.grid);
    const auto grids = VolumeGrid::listGrids(o.file);
    if (o.json) {
        nlohmann::json all = nlohmann::json::array();
        for (const auto& [name, type] : grids) all.push_back({{"name", name}, {"type", type}});
        const nlohmann::json j = {
            {"file", o.file},
            {"grid", grid.name()},
            {"type", "float"},
            {"description", grid.description()},
            {"voxel_size_mm", grid.voxelSizeMm()},
            {"bounds_min_mm", point(grid.boundsMinMm())},
            {"bounds_max_mm", point(grid.boundsMaxMm())},
            {"min_value", grid.minValue()},
            {"mean_value", grid.meanValue()},
            {"max_value", grid.maxValue()},
            {"active_voxels", grid.activeVoxelCount()},
            {"grids", all},
        };
        std::cout << jsonText(j) << "\n";
        return;
    }
    std::printf("%-15s%s\n", "file", o.file.c_str());
    printSummary(grid);
    if (grids.size() > 1) {
        std::string list;
        for (const auto& [name, type] : grids) list += (list.empty() ? "" : ", ") + name + " (" + type + ")";
        std::printf("%-15s%s\n", "grids in file", list.c_str());
    }
}

}  // namespace

void addVolumeCommands(CLI::App& app) {
    CLI::App* volume = app.add_subcommand("volume", "OpenVDB density grids for bulk scattering in glass");
    volume->require_subcommand(1);

    auto m = std::make_shared<VolumeMakeCommandOptions>();
    CLI::App* make = volume->add_subcommand("make", "write a procedural density grid (.vdb) filling an element's cylinder");
    make->add_option("--kind", m->kind, "haze, striae, bubbles or inclusions")
        ->required()
        ->check(CLI::IsMember({"haze", "striae", "bubbles", "inclusions"}));
    make->add_option("--radius", m->make.radiusMm, "cylinder radius in mm (the element's clear radius; default 12)")
        ->check(CLI::PositiveNumber);
    make->add_option("--thickness", m->make.thicknessMm, "element thickness in mm, along z from 0 (default 6)")
        ->check(CLI::PositiveNumber);
    make->add_option("--voxel", m->make.voxelMm, "voxel edge in mm (default 0.1)")->check(CLI::PositiveNumber);
    make->add_option("--seed", m->make.seed, "random seed (default 1)")->check(CLI::NonNegativeNumber);
    make->add_option("--density", m->make.density, "peak relative density: values lie in [0, D] (default 1)")
        ->check(CLI::PositiveNumber);
    make->add_option("--count", m->make.count,
                     "bubbles (default 40), stones (inclusions, default 8) or sheets (striae, default 12)")
        ->check(CLI::PositiveNumber);
    make->add_option("--feature", m->make.featureMm,
                     "bubble radius, stria width (FWHM) or stone diameter in mm (default 0.15)")
        ->check(CLI::PositiveNumber);
    make->add_option("--correlation", m->make.correlationMm, "haze: correlation length in mm (default radius/4)")
        ->check(CLI::PositiveNumber);
    make->add_option("--variation", m->make.variation,
                     "haze: values in [(1 - V)·density, density] (default 0.3)")
        ->check(CLI::Range(0.0, 1.0));
    make->add_option("--name", m->make.gridName, "grid name (default density)");
    make->add_option("-o,--output", m->output, ".vdb file to write")->required();
    make->callback([m, make] {
        m->countGiven = make->count("--count") > 0;
        runMake(*m);
    });

    auto i = std::make_shared<VolumeInfoCommandOptions>();
    CLI::App* info = volume->add_subcommand("info", "summary of a density grid: name, bounds, voxel size, values");
    info->add_option("FILE", i->file, ".vdb file")->required();
    info->add_option("--grid", i->grid, "grid name (default: the first float grid)");
    info->add_flag("--json", i->json, "print one JSON object");
    info->callback([i] { runInfo(*i); });
}

}  // namespace flare::cli
