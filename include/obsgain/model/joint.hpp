// A joint's kind and the range its position may take.
#pragma once

#include <numbers>

namespace obsgain {

enum class JointType { revolute, prismatic };

// Where a joint's position q_i may lie. A continuous revolute joint enters the dynamics only through
// sin/cos, so its whole range is one period.
struct JointDomain {
  JointType type = JointType::revolute;
  bool continuous = true;
  double lower = -std::numbers::pi;
  double upper = std::numbers::pi;
};

}  // namespace obsgain
