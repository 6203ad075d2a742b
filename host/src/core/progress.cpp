#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/progress.hpp>

#include <algorithm>

namespace terracl {

namespace {
std::function<bool()>& stop_check() {
  static std::function<bool()> check;
  return check;
}
}  // namespace

void set_stop_check(std::function<bool()> check) { stop_check() = std::move(check); }

bool stop_requested() { return stop_check() && stop_check()(); }

void report_progress(const Progress& p, const std::string& stage, double fraction, const std::string& message) {
  if (p && !p(std::clamp(fraction, 0.0, 1.0), message)) throw Cancelled(stage);
}

Progress scaled_progress(const Progress& parent, double begin, double end) {
  if (!parent) return {};
  return [parent, begin, end](double f, const std::string& m) { return parent(begin + (end - begin) * f, m); };
}

}  // namespace terracl
