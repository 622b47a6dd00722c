#include "report/gnuplot.h"

#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace omni::report {

std::string Datablock(const std::string& name, const std::vector<std::vector<double>>& rows) {
  std::ostringstream out;
  out.precision(9);
  out << "$" << name << " << EOD\n";
  for (const auto& row : rows) {
    for (size_t i = 0; i < row.size(); ++i) out << (i ? " " : "") << row[i];
    out << "\n";
  }
  out << "EOD\n";
  return out.str();
}

bool RunGnuplot(const std::string& script, std::string* error) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    *error = "gnuplot is not installed (apt-get install gnuplot-nox)";
    return false;
  }
  // gnuplot's own messages (few; they name the script line) go to our stderr.
  FILE* pipe = popen("gnuplot", "w");
  if (!pipe) {
    *error = "could not start gnuplot";
    return false;
  }
  const bool written = std::fwrite(script.data(), 1, script.size(), pipe) == script.size();
  const int status = pclose(pipe);
  if (!written || status != 0) {
    *error = "gnuplot failed (exit status " + std::to_string(status) + ")";
    return false;
  }
  return true;
}

}  // namespace omni::report
