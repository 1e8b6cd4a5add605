#pragma once
// Private: what a Model holds besides its description (the KDL chain and index maps).

#include <kdl/chain.hpp>
#include <map>
#include <string>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench {

struct Model::Impl {
  LimbDescription description;
  /// One KDL segment per description joint (fixed ones as Joint::None), then one fixed
  /// "isowrench_endpoint" segment whose tip is the endpoint.
  KDL::Chain chain;
  std::vector<int> movable;               ///< description.joints index of each column
  std::vector<std::string> joint_names;   ///< column order
  std::vector<bool> revolute;             ///< column order
  std::map<std::string, int> link_segments;  ///< link -> KDL segment count ending at its frame
  int endpoint_link_segments = 0;         ///< segment count ending at the endpoint link
  double chain_length = 0.0;
};

/// Build the KDL chain for a validated description (used by Model and by tests).
KDL::Chain BuildKdlChain(const LimbDescription& description);

}  // namespace isowrench
