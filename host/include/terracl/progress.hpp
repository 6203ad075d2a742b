// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Progress reporting for long stages (GDAL's convention): the callback receives the completed
/// fraction in [0, 1] and a message, and returns false to ask the stage to stop.
#include <functional>
#include <string>

namespace terracl {

/// An empty function means "no reporting".
using Progress = std::function<bool(double fraction, const std::string& message)>;

/// Calls `p` when set; throws Cancelled(stage) when it returns false.
void report_progress(const Progress& p, const std::string& stage, double fraction, const std::string& message);

/// Maps [0, 1] of a sub-task onto [begin, end] of the parent's progress.
Progress scaled_progress(const Progress& parent, double begin, double end);

}  // namespace terracl
