// ROS 2 messages as CDR (XCDR1, little-endian) and their ros2msg schemas, for MCAP files.
// CDR rules used: a primitive of size n is aligned to n bytes counted from the end of the 4-byte
// encapsulation header; string = u32 length including the terminating NUL, the bytes, the NUL;
// sequence = u32 count, then the elements; fixed arrays have no count.
#include <cstring>

#include "visnav/mcap.hpp"

namespace visnav::ros2 {
namespace {

class CdrOut {
 public:
  CdrOut() { buf_ = {0x00, 0x01, 0x00, 0x00}; }  // CDR_LE, options 0
  template <typename T>
  void put(T v) {
    align(sizeof(T));
    const std::size_t at = buf_.size();
    buf_.resize(at + sizeof(T));
    std::memcpy(buf_.data() + at, &v, sizeof(T));  // little-endian host (x86-64, aarch64)
  }
  void str(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size() + 1));
    buf_.insert(buf_.end(), s.begin(), s.end());
    buf_.push_back(0);
  }
  void bytes(const std::vector<std::uint8_t>& b) {
    put<std::uint32_t>(static_cast<std::uint32_t>(b.size()));
    buf_.insert(buf_.end(), b.begin(), b.end());
  }
  void header(const dds::msg::Header& h) {
    put<std::int32_t>(h.stamp.sec);
    put<std::uint32_t>(h.stamp.nanosec);
    str(h.frame_id);
  }
  void vec3(double x, double y, double z) { put(x); put(y); put(z); }
  std::vector<std::uint8_t> take() { return std::move(buf_); }

 private:
  void align(std::size_t n) {
    while ((buf_.size() - 4) % n != 0) buf_.push_back(0);
  }
  std::vector<std::uint8_t> buf_;
};

class CdrIn {
 public:
  explicit CdrIn(const std::vector<std::uint8_t>& b) : buf_(b) {}
  Status start() {
    if (buf_.size() < 4) return fail(ErrorCode::parse_error, "CDR: shorter than the encapsulation header");
    if (buf_[1] != 0x01) return fail(ErrorCode::parse_error, "CDR: not little-endian CDR (encapsulation " + std::to_string(buf_[1]) + ")");
    pos_ = 4;
    return ok();
  }
  template <typename T>
  Status get(T& v, const char* field) {
    while ((pos_ - 4) % sizeof(T) != 0) ++pos_;
    if (pos_ + sizeof(T) > buf_.size()) return Error{std::string("CDR: field '") + field + "' runs past the end", ErrorCode::parse_error, {{}, 0, field}};
    std::memcpy(&v, buf_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return ok();
  }
  Status str(std::string& s, const char* field) {
    std::uint32_t n = 0;
    VISNAV_TRY(get(n, field));
    if (n > buf_.size() - pos_) return Error{std::string("CDR: string '") + field + "' runs past the end", ErrorCode::parse_error, {{}, 0, field}};
    s.assign(reinterpret_cast<const char*>(buf_.data() + pos_), n > 0 ? n - 1 : 0);
    pos_ += n;
    return ok();
  }
  Status bytes(std::vector<std::uint8_t>& b, const char* field) {
    std::uint32_t n = 0;
    VISNAV_TRY(get(n, field));
    if (n > buf_.size() - pos_) return Error{std::string("CDR: sequence '") + field + "' runs past the end", ErrorCode::parse_error, {{}, 0, field}};
    b.assign(buf_.begin() + static_cast<std::ptrdiff_t>(pos_), buf_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
    pos_ += n;
    return ok();
  }
  Status header(dds::msg::Header& h) {
    VISNAV_TRY(get(h.stamp.sec, "header.stamp.sec"));
    VISNAV_TRY(get(h.stamp.nanosec, "header.stamp.nanosec"));
    return str(h.frame_id, "header.frame_id");
  }
  Status vec3(double& x, double& y, double& z, const char* field) {
    VISNAV_TRY(get(x, field));
    VISNAV_TRY(get(y, field));
    return get(z, field);
  }

 private:
  const std::vector<std::uint8_t>& buf_;
  std::size_t pos_ = 0;
};

constexpr const char* kSep = "================================================================================\n";
const std::string kTime = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const std::string kHeader = std::string("MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n") + kSep + kTime;
const std::string kVector3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
const std::string kTwistBody = "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n";

}  // namespace

std::string schema_text(std::string_view type) {
  if (type == "sensor_msgs/msg/Image")
    return std::string("std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\n"
                       "uint32 step\nuint8[] data\n") + kSep + kHeader;
  if (type == "sensor_msgs/msg/CompressedImage")
    return std::string("std_msgs/Header header\nstring format\nuint8[] data\n") + kSep + kHeader;
  if (type == "geometry_msgs/msg/Twist") return kTwistBody + kSep + kVector3;
  if (type == "nav_msgs/msg/Odometry")
    return std::string("std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
                       "geometry_msgs/TwistWithCovariance twist\n") +
           kSep + kHeader + kSep +
           "MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n" + kSep +
           "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n" + kSep +
           "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n" + kSep +
           "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n" + kSep +
           "MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance\n" + kSep +
           "MSG: geometry_msgs/Twist\n" + kTwistBody + kSep + kVector3;
  if (type == "sensor_msgs/msg/Joy")
    return std::string("std_msgs/Header header\nfloat32[] axes\nint32[] buttons\n") + kSep + kHeader;
  if (type == "visnav/msg/Telemetry")
    return std::string("std_msgs/Header header\nuint64 sequence_number\nstring node_path\nstring map_node\nstring edge\n"
                       "float64 distance_m\nint32 matches\nint32 inliers\nfloat64 offset_px\nfloat64 linear_mps\n"
                       "float64 angular_radps\nstring status\n") + kSep + kHeader;
  return {};
}

std::vector<std::uint8_t> encode(const dds::msg::Image& m) {
  CdrOut o;
  o.header(m.header);
  o.put(m.height);
  o.put(m.width);
  o.str(m.encoding);
  o.put(m.is_bigendian);
  o.put(m.step);
  o.bytes(m.data);
  return o.take();
}

std::vector<std::uint8_t> encode(const dds::msg::CompressedImage& m) {
  CdrOut o;
  o.header(m.header);
  o.str(m.format);
  o.bytes(m.data);
  return o.take();
}

std::vector<std::uint8_t> encode(const dds::msg::Odometry& m) {
  CdrOut o;
  o.header(m.header);
  o.str(m.child_frame_id);
  const auto& p = m.pose.pose;
  o.vec3(p.position.x, p.position.y, p.position.z);
  o.put(p.orientation.x);
  o.put(p.orientation.y);
  o.put(p.orientation.z);
  o.put(p.orientation.w);
  for (double c : m.pose.covariance) o.put(c);
  o.vec3(m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z);
  o.vec3(m.twist.twist.angular.x, m.twist.twist.angular.y, m.twist.twist.angular.z);
  for (double c : m.twist.covariance) o.put(c);
  return o.take();
}

std::vector<std::uint8_t> encode(const dds::msg::Twist& m) {
  CdrOut o;
  o.vec3(m.linear.x, m.linear.y, m.linear.z);
  o.vec3(m.angular.x, m.angular.y, m.angular.z);
  return o.take();
}

std::vector<std::uint8_t> encode(const dds::msg::Telemetry& m) {
  CdrOut o;
  o.header(m.header);
  o.put(m.sequence_number);
  o.str(m.node_path);
  o.str(m.map_node);
  o.str(m.edge);
  o.put(m.distance_m);
  o.put(m.matches);
  o.put(m.inliers);
  o.put(m.offset_px);
  o.put(m.linear_mps);
  o.put(m.angular_radps);
  o.str(m.status);
  return o.take();
}

std::vector<std::uint8_t> encode(const dds::msg::Joy& m) {
  CdrOut o;
  o.header(m.header);
  o.put<std::uint32_t>(static_cast<std::uint32_t>(m.axes.size()));
  for (float a : m.axes) o.put(a);
  o.put<std::uint32_t>(static_cast<std::uint32_t>(m.buttons.size()));
  for (std::int32_t b : m.buttons) o.put(b);
  return o.take();
}

Result<dds::msg::Joy> decode_joy(const std::vector<std::uint8_t>& cdr) {
  CdrIn in(cdr);
  dds::msg::Joy m;
  VISNAV_TRY(in.start());
  VISNAV_TRY(in.header(m.header));
  std::uint32_t n = 0;
  VISNAV_TRY(in.get(n, "axes"));
  if (n > cdr.size() / 4) return Error{"CDR: sequence 'axes' runs past the end", ErrorCode::parse_error, {{}, 0, "axes"}};
  m.axes.resize(n);
  for (float& a : m.axes) VISNAV_TRY(in.get(a, "axes"));
  VISNAV_TRY(in.get(n, "buttons"));
  if (n > cdr.size() / 4) return Error{"CDR: sequence 'buttons' runs past the end", ErrorCode::parse_error, {{}, 0, "buttons"}};
  m.buttons.resize(n);
  for (std::int32_t& b : m.buttons) VISNAV_TRY(in.get(b, "buttons"));
  return m;
}

Result<dds::msg::Image> decode_image(const std::vector<std::uint8_t>& cdr) {
  CdrIn in(cdr);
  dds::msg::Image m;
  VISNAV_TRY(in.start());
  VISNAV_TRY(in.header(m.header));
  VISNAV_TRY(in.get(m.height, "height"));
  VISNAV_TRY(in.get(m.width, "width"));
  VISNAV_TRY(in.str(m.encoding, "encoding"));
  VISNAV_TRY(in.get(m.is_bigendian, "is_bigendian"));
  VISNAV_TRY(in.get(m.step, "step"));
  VISNAV_TRY(in.bytes(m.data, "data"));
  return m;
}

Result<dds::msg::CompressedImage> decode_compressed_image(const std::vector<std::uint8_t>& cdr) {
  CdrIn in(cdr);
  dds::msg::CompressedImage m;
  VISNAV_TRY(in.start());
  VISNAV_TRY(in.header(m.header));
  VISNAV_TRY(in.str(m.format, "format"));
  VISNAV_TRY(in.bytes(m.data, "data"));
  return m;
}

Result<dds::msg::Odometry> decode_odometry(const std::vector<std::uint8_t>& cdr) {
  CdrIn in(cdr);
  dds::msg::Odometry m;
  VISNAV_TRY(in.start());
  VISNAV_TRY(in.header(m.header));
  VISNAV_TRY(in.str(m.child_frame_id, "child_frame_id"));
  auto& p = m.pose.pose;
  VISNAV_TRY(in.vec3(p.position.x, p.position.y, p.position.z, "pose.position"));
  VISNAV_TRY(in.get(p.orientation.x, "pose.orientation"));
  VISNAV_TRY(in.get(p.orientation.y, "pose.orientation"));
  VISNAV_TRY(in.get(p.orientation.z, "pose.orientation"));
  VISNAV_TRY(in.get(p.orientation.w, "pose.orientation"));
  for (double& c : m.pose.covariance) VISNAV_TRY(in.get(c, "pose.covariance"));
  auto& t = m.twist.twist;
  VISNAV_TRY(in.vec3(t.linear.x, t.linear.y, t.linear.z, "twist.linear"));
  VISNAV_TRY(in.vec3(t.angular.x, t.angular.y, t.angular.z, "twist.angular"));
  for (double& c : m.twist.covariance) VISNAV_TRY(in.get(c, "twist.covariance"));
  return m;
}

Result<dds::msg::Twist> decode_twist(const std::vector<std::uint8_t>& cdr) {
  CdrIn in(cdr);
  dds::msg::Twist m;
  VISNAV_TRY(in.start());
  VISNAV_TRY(in.vec3(m.linear.x, m.linear.y, m.linear.z, "linear"));
  VISNAV_TRY(in.vec3(m.angular.x, m.angular.y, m.angular.z, "angular"));
  return m;
}

Result<dds::msg::Telemetry> decode_telemetry(const std::vector<std::uint8_t>& cdr) {
  CdrIn in(cdr);
  dds::msg::Telemetry m;
  VISNAV_TRY(in.start());
  VISNAV_TRY(in.header(m.header));
  VISNAV_TRY(in.get(m.sequence_number, "sequence_number"));
  VISNAV_TRY(in.str(m.node_path, "node_path"));
  VISNAV_TRY(in.str(m.map_node, "map_node"));
  VISNAV_TRY(in.str(m.edge, "edge"));
  VISNAV_TRY(in.get(m.distance_m, "distance_m"));
  VISNAV_TRY(in.get(m.matches, "matches"));
  VISNAV_TRY(in.get(m.inliers, "inliers"));
  VISNAV_TRY(in.get(m.offset_px, "offset_px"));
  VISNAV_TRY(in.get(m.linear_mps, "linear_mps"));
  VISNAV_TRY(in.get(m.angular_radps, "angular_radps"));
  VISNAV_TRY(in.str(m.status, "status"));
  return m;
}

}  // namespace visnav::ros2
