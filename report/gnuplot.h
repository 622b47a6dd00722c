// Plots through gnuplot (an external program, as mrcal uses it): a script with its data inline
// (datablocks), rendered to PNG with the pngcairo terminal.
#pragma once

#include <string>
#include <vector>

namespace omni::report {

// A datablock `$name << EOD ... EOD` of rows of numbers.
std::string Datablock(const std::string& name, const std::vector<std::vector<double>>& rows);

// Runs gnuplot on `script` (which sets its own output file); false with *error set if gnuplot
// is missing or fails.
bool RunGnuplot(const std::string& script, std::string* error);

}  // namespace omni::report
