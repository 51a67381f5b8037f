// The design as the controller's code and configuration read it: a C++ header of constexpr values with the
// certificate in a comment (and, for a controller that links obsgain::runtime, the model and observer to build
// the Observer from), a ROS 2 parameters file, and the runtime's own observer file.
#pragma once

#include "obsgain/deployment/deployment.hpp"
#include "obsgain/runtime/exported_observer.hpp"

#include <string>

namespace obsgain {

// The model and the selected observer, with the deployment's sub-steps and sample period when there is one.
ExportedObserver exported_observer(const Model& model, const DeployedDesign& design);

// namespace_name: the C++ namespace the values live in.
std::string observer_header(const Model& model, const DeployedDesign& design,
                            const std::string& namespace_name = "observer_gains");
// node_name: the top-level key of the parameters file.
std::string ros2_parameters(const DeployedDesign& design, const std::string& node_name = "velocity_observer");

}  // namespace obsgain
