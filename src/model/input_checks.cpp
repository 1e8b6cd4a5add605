// Warnings channel, stiffness limits and name suggestions (include/isowrench/input_checks.hpp).

#include "isowrench/input_checks.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iostream>
#include <mutex>

#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

std::mutex& HandlerMutex() {
  static std::mutex mutex;
  return mutex;
}

WarningHandler& Handler() {
  static WarningHandler handler;
  return handler;
}

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t up = row[j];
      bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                  std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

WarningHandler SetWarningHandler(WarningHandler handler) {
  std::lock_guard<std::mutex> lock(HandlerMutex());
  WarningHandler previous = std::move(Handler());
  Handler() = std::move(handler);
  return previous;
}

void Warn(const std::string& message) {
  std::lock_guard<std::mutex> lock(HandlerMutex());
  if (Handler()) {
    Handler()(message);
  } else {
    std::cerr << "isowrench: warning: " << message << "\n";
  }
}

struct WarningCollector::State {
  std::mutex mutex;
  std::vector<std::string> warnings;
};

WarningCollector::WarningCollector() : state_(std::make_shared<State>()) {
  std::shared_ptr<State> state = state_;
  previous_ = SetWarningHandler([state](const std::string& message) {
    std::lock_guard<std::mutex> lock(state->mutex);
    state->warnings.push_back(message);
  });
}

WarningCollector::~WarningCollector() { SetWarningHandler(std::move(previous_)); }

std::vector<std::string> WarningCollector::warnings() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->warnings;
}

std::string WarningCollector::text() const { return util::Join(warnings(), "\n"); }

void CheckStiffnessValue(double stiffness, const std::string& where) {
  if (!std::isfinite(stiffness)) {
    throw Error(where + ": stiffness " + util::FormatNumber(stiffness) + " is not a finite number");
  }
  if (stiffness < 0) {
    throw Error(where + ": stiffness " + util::FormatNumber(stiffness) +
                " is negative; it must be >= 0");
  }
  if (stiffness > kMaxStiffness) {
    throw Error(where + ": stiffness " + util::FormatNumber(stiffness) +
                " exceeds the physical maximum " + util::FormatNumber(kMaxStiffness) +
                " (N/m or N·m/rad; a 1 mm long 10 cm steel bar is 2e12 N/m, see docs/model.md)");
  }
}

std::string ClosestName(const std::string& name, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::max<size_t>(2, name.size() / 3) + 1;
  for (const std::string& c : candidates) {
    size_t d = EditDistance(name, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

std::string DidYouMean(const std::string& name, const std::vector<std::string>& candidates) {
  std::string best = ClosestName(name, candidates);
  return best.empty() ? std::string() : " (did you mean '" + best + "'?)";
}

}  // namespace isowrench
