// The llc subcommands; each returns the process exit code.
#pragma once

#include "tool_common.hpp"

namespace llc_tool {
int runPairs(const Args& args);
int runFeatures(const Args& args);
int runTrain(const Args& args);
int runScore(const Args& args);
int runEvaluate(const Args& args);
int runSimulate(const Args& args);
}  // namespace llc_tool
