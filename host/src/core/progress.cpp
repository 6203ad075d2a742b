#include <terracl/error.hpp>
#include <terracl/progress.hpp>

#include <algorithm>

namespace terracl {

void report_progress(const Progress& p, const std::string& stage, double fraction, const std::string& message) {
  if (p && !p(std::clamp(fraction, 0.0, 1.0), message)) throw Cancelled(stage);
}

Progress scaled_progress(const Progress& parent, double begin, double end) {
  if (!parent) return {};
  return [parent, begin, end](double f, const std::string& m) { return parent(begin + (end - begin) * f, m); };
}

}  // namespace terracl
