// The policy and critic networks' architecture, as configs name it: without libtorch, so that
// config readers and the code above them compile without its headers (common/policy.h).
#pragma once

#include <string>
#include <vector>

namespace ragdoll {

struct NetworkConfig {
  std::vector<int> hidden_units = {512, 512};
  std::string activation = "tanh";  // tanh | relu | elu
  double init_log_std = -1.0;       // initial action noise: std = exp(-1) = 0.37
};

}  // namespace ragdoll
