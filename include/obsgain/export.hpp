// The design as the controller's code and configuration read it: a C++ header of constexpr values with the
// certificate in a comment, and a ROS 2 parameters file.
#pragma once

#include "obsgain/design.hpp"

#include <string>

namespace obsgain {

// namespace_name: the C++ namespace the values live in.
std::string observer_header(const Design& design, const std::string& namespace_name = "observer_gains");
// node_name: the top-level key of the parameters file.
std::string ros2_parameters(const Design& design, const std::string& node_name = "velocity_observer");

}  // namespace obsgain
