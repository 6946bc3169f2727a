// `flare dataset SPEC.json -o DIR`: a physically based flare data set (docs/dataset.md): N
// images drawn from a spec, each an EXR with its layers and a JSON of its exact scene and
// statistics, and an index (CSV and JSON). Shared among MPI ranks (mpirun) and job-array shards
// (--shard i/n); a killed run resumes, skipping the finished images.
#pragma once

#include <CLI/CLI.hpp>

namespace flare::cli {

void addDatasetCommand(CLI::App& app);

}  // namespace flare::cli
