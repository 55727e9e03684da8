#include "view/foxglove_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <regex>

namespace visnav::view {
namespace {

constexpr std::size_t kMaxIncomingFrame = 1 << 20;

std::uint32_t rol(std::uint32_t v, int n) { return (v << n) | (v >> (32 - n)); }

void put_le32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void put_le64(std::string& s, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

/// A server-to-client WebSocket frame (never masked), FIN set.
std::string ws_frame(std::uint8_t opcode, const std::string& payload) {
  std::string f;
  f.reserve(payload.size() + 10);
  f.push_back(static_cast<char>(0x80 | opcode));
  const std::size_t n = payload.size();
  if (n < 126) {
    f.push_back(static_cast<char>(n));
  } else if (n < 65536) {
    f.push_back(static_cast<char>(126));
    f.push_back(static_cast<char>((n >> 8) & 0xFF));
    f.push_back(static_cast<char>(n & 0xFF));
  } else {
    f.push_back(static_cast<char>(127));
    for (int i = 7; i >= 0; --i) f.push_back(static_cast<char>((static_cast<std::uint64_t>(n) >> (8 * i)) & 0xFF));
  }
  f += payload;
  return f;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

}  // namespace

std::string sha1(const std::string& data) {
  std::uint32_t h[5] = {0x67452301U, 0xEFCDAB89U, 0x98BADCFEU, 0x10325476U, 0xC3D2E1F0U};
  std::string m = data;
  const std::uint64_t bits = static_cast<std::uint64_t>(data.size()) * 8;
  m.push_back(static_cast<char>(0x80));
  while (m.size() % 64 != 56) m.push_back('\0');
  for (int i = 7; i >= 0; --i) m.push_back(static_cast<char>((bits >> (8 * i)) & 0xFF));
  for (std::size_t off = 0; off < m.size(); off += 64) {
    std::uint32_t w[80];
    for (int i = 0; i < 16; ++i)
      w[i] = (static_cast<std::uint32_t>(static_cast<unsigned char>(m[off + 4 * i])) << 24) |
             (static_cast<std::uint32_t>(static_cast<unsigned char>(m[off + 4 * i + 1])) << 16) |
             (static_cast<std::uint32_t>(static_cast<unsigned char>(m[off + 4 * i + 2])) << 8) |
             static_cast<std::uint32_t>(static_cast<unsigned char>(m[off + 4 * i + 3]));
    for (int i = 16; i < 80; ++i) w[i] = rol(w[i - 3] ^ w[i - 8] ^ w[i - 14] ^ w[i - 16], 1);
    std::uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4];
    for (int i = 0; i < 80; ++i) {
      std::uint32_t f = 0, k = 0;
      if (i < 20) { f = (b & c) | (~b & d); k = 0x5A827999U; }
      else if (i < 40) { f = b ^ c ^ d; k = 0x6ED9EBA1U; }
      else if (i < 60) { f = (b & c) | (b & d) | (c & d); k = 0x8F1BBCDCU; }
      else { f = b ^ c ^ d; k = 0xCA62C1D6U; }
      const std::uint32_t t = rol(a, 5) + f + e + k + w[i];
      e = d;
      d = c;
      c = rol(b, 30);
      b = a;
      a = t;
    }
    h[0] += a; h[1] += b; h[2] += c; h[3] += d; h[4] += e;
  }
  std::string out;
  for (std::uint32_t v : h)
    for (int i = 3; i >= 0; --i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  return out;
}

std::string base64(const std::string& data) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < data.size(); i += 3) {
    const std::uint32_t v = (static_cast<std::uint32_t>(static_cast<unsigned char>(data[i])) << 16) |
                            (static_cast<std::uint32_t>(static_cast<unsigned char>(data[i + 1])) << 8) |
                            static_cast<std::uint32_t>(static_cast<unsigned char>(data[i + 2]));
    out += t[(v >> 18) & 63]; out += t[(v >> 12) & 63]; out += t[(v >> 6) & 63]; out += t[v & 63];
  }
  if (i + 1 == data.size()) {
    const std::uint32_t v = static_cast<std::uint32_t>(static_cast<unsigned char>(data[i])) << 16;
    out += t[(v >> 18) & 63]; out += t[(v >> 12) & 63]; out += "==";
  } else if (i + 2 == data.size()) {
    const std::uint32_t v = (static_cast<std::uint32_t>(static_cast<unsigned char>(data[i])) << 16) |
                            (static_cast<std::uint32_t>(static_cast<unsigned char>(data[i + 1])) << 8);
    out += t[(v >> 18) & 63]; out += t[(v >> 12) & 63]; out += t[(v >> 6) & 63]; out += '=';
  }
  return out;
}

std::string json_escape(const std::string& s) {
  std::string o;
  o.reserve(s.size() + 8);
  for (char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\r': o += "\\r"; break;
      case '\t': o += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char b[8];
          std::snprintf(b, sizeof b, "\\u%04x", c);
          o += b;
        } else {
          o.push_back(c);
        }
    }
  }
  return o;
}

Result<std::unique_ptr<FoxgloveServer>> FoxgloveServer::create(int port, std::vector<ChannelInfo> channels,
                                                               bool all_interfaces, std::size_t max_queue_bytes) {
  if (port < 0 || port > 65535) return fail("view port " + std::to_string(port) + " is out of range [0, 65535]");
  std::unique_ptr<FoxgloveServer> s(new FoxgloveServer());
  s->channels_ = std::move(channels);
  s->max_queue_bytes_ = max_queue_bytes;
  s->listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (s->listen_fd_ < 0) return fail(std::string("view: socket: ") + std::strerror(errno));
  const int one = 1;
  (void)::setsockopt(s->listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(all_interfaces ? INADDR_ANY : INADDR_LOOPBACK);
  if (::bind(s->listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
    return fail("view: cannot listen on port " + std::to_string(port) + ": " + std::strerror(errno));
  if (::listen(s->listen_fd_, 16) != 0) return fail(std::string("view: listen: ") + std::strerror(errno));
  socklen_t len = sizeof addr;
  (void)::getsockname(s->listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  s->port_ = ntohs(addr.sin_port);
  if (::pipe2(s->wake_fd_, O_NONBLOCK | O_CLOEXEC) != 0) return fail(std::string("view: pipe: ") + std::strerror(errno));
  s->thread_ = std::thread([raw = s.get()] { raw->loop(); });
  return s;
}

FoxgloveServer::~FoxgloveServer() {
  stop_ = true;
  wake();
  if (thread_.joinable()) thread_.join();
  for (auto& [fd, c] : clients_) ::close(fd);
  if (listen_fd_ >= 0) ::close(listen_fd_);
  for (int fd : wake_fd_)
    if (fd >= 0) ::close(fd);
}

void FoxgloveServer::wake() {
  const char b = 1;
  if (wake_fd_[1] >= 0) (void)!::write(wake_fd_[1], &b, 1);
}

bool FoxgloveServer::has_subscribers(std::uint32_t channel_id) const {
  std::lock_guard lock(mutex_);
  for (const auto& [fd, c] : clients_)
    for (const auto& [sub, ch] : c.subscriptions)
      if (ch == channel_id) return true;
  return false;
}

ServerStats FoxgloveServer::stats() const {
  std::lock_guard lock(mutex_);
  ServerStats s = stats_;
  s.clients_now = clients_.size();
  s.queued_bytes = 0;
  for (const auto& [fd, c] : clients_) s.queued_bytes += c.out_bytes;
  return s;
}

void FoxgloveServer::enqueue(Client& c, std::string frame, bool droppable) {
  // Droppable frames are tagged by a leading marker kept out of the socket: we keep two queues'
  // worth of information in one deque by remembering which entries may go.
  c.out_bytes += frame.size();
  std::string tagged(1, droppable ? '\1' : '\0');
  tagged += frame;
  c.out.push_back(std::move(tagged));
  // Over the bound: drop the oldest droppable frames (never the one being sent).
  for (auto it = c.out.begin(); c.out_bytes > max_queue_bytes_ && it != c.out.end();) {
    if (it == c.out.begin() && c.out_front_sent > 0) { ++it; continue; }
    if ((*it)[0] == '\1') {
      c.out_bytes -= it->size() - 1;
      it = c.out.erase(it);
      ++stats_.messages_dropped;
    } else {
      ++it;
    }
  }
}

void FoxgloveServer::publish(std::uint32_t channel_id, std::uint64_t timestamp_ns, const std::string& payload) {
  bool any = false;
  {
    std::lock_guard lock(mutex_);
    for (auto& [fd, c] : clients_) {
      if (!c.handshaken || c.closing) continue;
      for (const auto& [sub, ch] : c.subscriptions) {
        if (ch != channel_id) continue;
        std::string body;
        body.reserve(payload.size() + 13);
        body.push_back('\x01');  // message data
        put_le32(body, sub);
        put_le64(body, timestamp_ns);
        body += payload;
        enqueue(c, ws_frame(0x2, body), true);
        any = true;
      }
    }
  }
  if (any) wake();
}

void FoxgloveServer::loop() {
  std::vector<pollfd> fds;
  while (!stop_) {
    fds.clear();
    fds.push_back({listen_fd_, POLLIN, 0});
    fds.push_back({wake_fd_[0], POLLIN, 0});
    {
      std::lock_guard lock(mutex_);
      for (const auto& [fd, c] : clients_)
        fds.push_back({fd, static_cast<short>(POLLIN | (c.out.empty() ? 0 : POLLOUT)), 0});
    }
    if (::poll(fds.data(), fds.size(), 100) < 0 && errno != EINTR) break;
    if ((fds[1].revents & POLLIN) != 0) {
      char buf[256];
      while (::read(wake_fd_[0], buf, sizeof buf) > 0) {
      }
    }
    if ((fds[0].revents & POLLIN) != 0) accept_clients();
    std::lock_guard lock(mutex_);
    for (std::size_t i = 2; i < fds.size(); ++i) {
      auto it = clients_.find(fds[i].fd);
      if (it == clients_.end()) continue;
      Client& c = it->second;
      bool keep = true;
      if ((fds[i].revents & (POLLERR | POLLHUP | POLLNVAL)) != 0 && (fds[i].revents & POLLIN) == 0) keep = false;
      if (keep && (fds[i].revents & POLLIN) != 0) keep = read_client(c);
      if (keep && !c.out.empty()) keep = write_client(c);
      if (keep && c.closing && c.out.empty()) keep = false;
      if (!keep) {
        ::close(c.fd);
        clients_.erase(it);
      }
    }
  }
}

void FoxgloveServer::accept_clients() {
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    const int one = 1;
    (void)::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    std::lock_guard lock(mutex_);
    Client c;
    c.fd = fd;
    clients_.emplace(fd, std::move(c));
    ++stats_.clients_accepted;
  }
}

bool FoxgloveServer::read_client(Client& c) {
  char buf[16384];
  for (;;) {
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
    if (n > 0) {
      c.in.append(buf, static_cast<std::size_t>(n));
      if (c.in.size() > 2 * kMaxIncomingFrame) return false;
      continue;
    }
    if (n == 0) return false;  // peer closed
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) break;
    return false;
  }
  if (!c.handshaken) {
    if (c.in.find("\r\n\r\n") == std::string::npos) return c.in.size() < 16384;
    if (!handshake(c)) return false;
  }
  return handle_frames(c);
}

bool FoxgloveServer::handshake(Client& c) {
  const std::size_t end = c.in.find("\r\n\r\n");
  const std::string request = c.in.substr(0, end);
  c.in.erase(0, end + 4);
  std::string key;
  std::size_t pos = 0;
  while (pos < request.size()) {
    std::size_t nl = request.find("\r\n", pos);
    if (nl == std::string::npos) nl = request.size();
    const std::string line = request.substr(pos, nl - pos);
    pos = nl + 2;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    if (lower(line.substr(0, colon)) == "sec-websocket-key") {
      key = line.substr(colon + 1);
      key.erase(0, key.find_first_not_of(' '));
      key.erase(key.find_last_not_of(" \r") + 1);
    }
  }
  if (key.empty()) {
    const std::string r = "HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n";
    (void)!::send(c.fd, r.data(), r.size(), MSG_NOSIGNAL);
    return false;
  }
  const std::string accept = base64(sha1(key + "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"));
  std::string response =
      "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: " + accept +
      "\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n";
  std::string tagged(1, '\0');
  tagged += response;
  c.out.push_back(std::move(tagged));
  c.out_bytes += response.size();
  c.handshaken = true;
  const std::string info = "{\"op\":\"serverInfo\",\"name\":\"visnav\",\"capabilities\":[],\"supportedEncodings\":[],"
                           "\"metadata\":{},\"sessionId\":\"" +
                           std::to_string(std::chrono::system_clock::now().time_since_epoch().count()) + "\"}";
  enqueue(c, ws_frame(0x1, info), false);
  std::string adv = "{\"op\":\"advertise\",\"channels\":[";
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    const auto& ch = channels_[i];
    if (i > 0) adv += ',';
    adv += "{\"id\":" + std::to_string(i + 1) + ",\"topic\":\"" + json_escape(ch.topic) +
           "\",\"encoding\":\"" + json_escape(ch.encoding) + "\",\"schemaName\":\"" + json_escape(ch.schema_name) +
           "\",\"schema\":\"" + json_escape(ch.schema) + "\",\"schemaEncoding\":\"" + json_escape(ch.schema_encoding) + "\"}";
  }
  adv += "]}";
  enqueue(c, ws_frame(0x1, adv), false);
  return true;
}

bool FoxgloveServer::handle_frames(Client& c) {
  for (;;) {
    if (c.in.size() < 2) return true;
    const auto b0 = static_cast<unsigned char>(c.in[0]);
    const auto b1 = static_cast<unsigned char>(c.in[1]);
    const std::uint8_t opcode = b0 & 0x0F;
    if ((b1 & 0x80) == 0) return false;  // clients must mask (RFC 6455 5.1)
    std::uint64_t len = b1 & 0x7F;
    std::size_t head = 2;
    if (len == 126) {
      if (c.in.size() < 4) return true;
      len = (static_cast<std::uint64_t>(static_cast<unsigned char>(c.in[2])) << 8) | static_cast<unsigned char>(c.in[3]);
      head = 4;
    } else if (len == 127) {
      if (c.in.size() < 10) return true;
      len = 0;
      for (int i = 0; i < 8; ++i) len = (len << 8) | static_cast<unsigned char>(c.in[2 + static_cast<std::size_t>(i)]);
      head = 10;
    }
    if (len > kMaxIncomingFrame) return false;
    if (c.in.size() < head + 4 + len) return true;
    const std::string mask = c.in.substr(head, 4);
    std::string payload = c.in.substr(head + 4, static_cast<std::size_t>(len));
    for (std::size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<char>(payload[i] ^ mask[i % 4]);
    c.in.erase(0, head + 4 + static_cast<std::size_t>(len));
    if (opcode == 0x1) {
      handle_text(c, payload);
    } else if (opcode == 0x8) {
      enqueue(c, ws_frame(0x8, payload.substr(0, 2)), false);
      c.closing = true;
      return true;
    } else if (opcode == 0x9) {
      enqueue(c, ws_frame(0xA, payload), false);
    }
    // binary (client publishing), pong, continuation: not used by this server's capabilities.
  }
}

void FoxgloveServer::handle_text(Client& c, const std::string& text) {
  static const std::regex op_re("\"op\"\\s*:\\s*\"([a-zA-Z]+)\"");
  static const std::regex sub_re("\\{[^{}]*\\}");
  static const std::regex id_re("\"id\"\\s*:\\s*([0-9]+)");
  static const std::regex ch_re("\"channelId\"\\s*:\\s*([0-9]+)");
  static const std::regex ids_re("\"subscriptionIds\"\\s*:\\s*\\[([^\\]]*)\\]");
  std::smatch m;
  if (!std::regex_search(text, m, op_re)) return;
  const std::string op = m[1].str();
  if (op == "subscribe") {
    const auto start = text.find("\"subscriptions\"");
    if (start == std::string::npos) return;
    const std::string list = text.substr(start);
    for (std::sregex_iterator it(list.begin(), list.end(), sub_re), end; it != end; ++it) {
      const std::string obj = it->str();
      std::smatch a, b;
      if (!std::regex_search(obj, a, id_re) || !std::regex_search(obj, b, ch_re)) continue;
      const auto channel = static_cast<std::uint32_t>(std::stoul(b[1].str()));
      if (channel == 0 || channel > channels_.size()) continue;
      c.subscriptions[static_cast<std::uint32_t>(std::stoul(a[1].str()))] = channel;
    }
  } else if (op == "unsubscribe") {
    if (!std::regex_search(text, m, ids_re)) return;
    const std::string ids = m[1].str();
    static const std::regex num("[0-9]+");
    for (std::sregex_iterator it(ids.begin(), ids.end(), num), end; it != end; ++it)
      c.subscriptions.erase(static_cast<std::uint32_t>(std::stoul(it->str())));
  }
}

bool FoxgloveServer::write_client(Client& c) {
  while (!c.out.empty()) {
    const std::string& f = c.out.front();  // f[0] is the droppable marker
    const std::size_t total = f.size() - 1;
    const ssize_t n = ::send(c.fd, f.data() + 1 + c.out_front_sent, total - c.out_front_sent, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno == EAGAIN || errno == EWOULDBLOCK;
    }
    c.out_front_sent += static_cast<std::size_t>(n);
    if (c.out_front_sent < total) return true;
    if (f[0] == '\1') ++stats_.messages_sent;
    c.out_bytes -= total;
    c.out_front_sent = 0;
    c.out.pop_front();
  }
  return true;
}

}  // namespace visnav::view
