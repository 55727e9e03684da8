// visnav SDK — the ROS 2 joystick message on the DDS layer (visnav/dds.hpp): sensor_msgs/msg/Joy
// as published by joy_node / joy_linux on /joy (DDS topic rt/joy). Used by the teleop plugin's
// `joy` input. Same conventions, ownership and thread-safety as visnav/dds.hpp.
#pragma once

#include <cstdint>
#include <vector>

#include "visnav/dds.hpp"

namespace visnav::dds {
namespace msg {

/// sensor_msgs/msg/Joy: axes in [-1, 1] (stick up / stick left = +1), buttons 0 or 1.
struct Joy {
  Header header;
  std::vector<float> axes;
  std::vector<std::int32_t> buttons;
};

}  // namespace msg

template <> struct MessageTraits<msg::Joy> { static constexpr const char* type_name = "sensor_msgs::msg::dds_::Joy_"; };

extern template class Writer<msg::Joy>;
extern template class Reader<msg::Joy>;
extern template class Subscription<msg::Joy>;

}  // namespace visnav::dds
