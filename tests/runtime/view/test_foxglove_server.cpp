// The live view's Foxglove WebSocket server (runtime/src/view): the handshake (RFC 6455 test
// vector), advertise/subscribe/message-data framing with a raw socket client, a client that
// never reads (bounded queue, other clients unaffected), and 10 connect/disconnect cycles.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <thread>

#include "view/foxglove_server.hpp"

using namespace visnav::view;

namespace {

/// A minimal WebSocket client over a blocking socket (masked frames, as RFC 6455 requires).
class RawClient {
 public:
  explicit RawClient(int port, bool small_buffer = false) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (small_buffer) {
      const int size = 4096;
      (void)::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &size, sizeof size);
    }
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~RawClient() { ::close(fd_); }
  bool handshake() {
    const std::string req = "GET / HTTP/1.1\r\nHost: localhost\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n"
                            "Sec-WebSocket-Version: 13\r\n\r\n";
    if (::send(fd_, req.data(), req.size(), 0) != static_cast<ssize_t>(req.size())) return false;
    while (buf_.find("\r\n\r\n") == std::string::npos)
      if (!fill(2.0)) return false;
    response_ = buf_.substr(0, buf_.find("\r\n\r\n"));
    buf_.erase(0, buf_.find("\r\n\r\n") + 4);
    return true;
  }
  void send_text(const std::string& text) {
    std::string f;
    f.push_back(static_cast<char>(0x81));
    f.push_back(static_cast<char>(0x80 | 126));
    f.push_back(static_cast<char>((text.size() >> 8) & 0xFF));
    f.push_back(static_cast<char>(text.size() & 0xFF));
    const char mask[4] = {0x12, 0x34, 0x56, 0x78};
    f.append(mask, 4);
    for (std::size_t i = 0; i < text.size(); ++i) f.push_back(static_cast<char>(text[i] ^ mask[i % 4]));
    (void)::send(fd_, f.data(), f.size(), 0);
  }
  /// Next frame: (opcode, payload); opcode -1 on timeout.
  std::pair<int, std::string> next(double timeout_s = 2.0) {
    for (;;) {
      if (buf_.size() >= 2) {
        std::uint64_t len = static_cast<unsigned char>(buf_[1]) & 0x7F;
        std::size_t head = 2;
        if (len == 126 && buf_.size() >= 4) {
          len = (static_cast<std::uint64_t>(static_cast<unsigned char>(buf_[2])) << 8) | static_cast<unsigned char>(buf_[3]);
          head = 4;
        } else if (len == 127 && buf_.size() >= 10) {
          len = 0;
          for (int i = 0; i < 8; ++i) len = (len << 8) | static_cast<unsigned char>(buf_[2 + static_cast<std::size_t>(i)]);
          head = 10;
        }
        if ((len < 126 || head > 2) && buf_.size() >= head + len) {
          const int op = static_cast<unsigned char>(buf_[0]) & 0x0F;
          std::string p = buf_.substr(head, static_cast<std::size_t>(len));
          buf_.erase(0, head + static_cast<std::size_t>(len));
          return {op, p};
        }
      }
      if (!fill(timeout_s)) return {-1, ""};
    }
  }
  [[nodiscard]] bool connected() const { return connected_; }
  [[nodiscard]] const std::string& response() const { return response_; }

 private:
  bool fill(double timeout_s) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout_s * 1000)) <= 0) return false;
    char b[65536];
    const ssize_t n = ::recv(fd_, b, sizeof b, 0);
    if (n <= 0) return false;
    buf_.append(b, static_cast<std::size_t>(n));
    return true;
  }
  int fd_ = -1;
  bool connected_ = false;
  std::string buf_, response_;
};

std::vector<ChannelInfo> two_channels() {
  return {{"/a", "json", "visnav.A", "{}", "jsonschema"}, {"/b", "json", "visnav.B", "{}", "jsonschema"}};
}

bool eventually(const std::function<bool()>& f, double timeout_s = 3.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!f()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

TEST(FoxgloveServer, HandshakeUsesTheRfc6455AcceptKey) {
  EXPECT_EQ(base64(sha1("dGhlIHNhbXBsZSBub25jZQ==258EAFA5-E914-47DA-95CA-C5AB0DC85B11")), "s3pPLMBiTxaQ9kYGzzhZRbK+xOo=");
  EXPECT_EQ(base64("ab"), "YWI=");
  EXPECT_EQ(json_escape("a\"b\\\n"), "a\\\"b\\\\\\n");
}

TEST(FoxgloveServer, AdvertisesAndSendsMessageDataToSubscribersOnly) {
  auto server = FoxgloveServer::create(0, two_channels());
  ASSERT_TRUE(server.ok()) << server.error().message;
  RawClient c((*server)->port());
  ASSERT_TRUE(c.connected());
  ASSERT_TRUE(c.handshake());
  EXPECT_NE(c.response().find("101 Switching Protocols"), std::string::npos);
  EXPECT_NE(c.response().find("s3pPLMBiTxaQ9kYGzzhZRbK+xOo="), std::string::npos);
  EXPECT_NE(c.response().find("foxglove.websocket.v1"), std::string::npos);
  auto info = c.next();
  EXPECT_EQ(info.first, 1);
  EXPECT_NE(info.second.find("\"op\":\"serverInfo\""), std::string::npos);
  auto adv = c.next();
  EXPECT_NE(adv.second.find("\"op\":\"advertise\""), std::string::npos);
  EXPECT_NE(adv.second.find("\"topic\":\"/b\""), std::string::npos);
  c.send_text("{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":7,\"channelId\":2}]}");
  ASSERT_TRUE(eventually([&] { return (*server)->has_subscribers(2); }));
  EXPECT_FALSE((*server)->has_subscribers(1));
  (*server)->publish(1, 5, "{\"not\":\"subscribed\"}");
  (*server)->publish(2, 123456789ULL, "{\"x\":1}");
  auto m = c.next();
  ASSERT_EQ(m.first, 2);
  ASSERT_EQ(m.second.size(), 13U + 7U);
  EXPECT_EQ(m.second[0], '\x01');
  std::uint32_t sub = 0;
  std::uint64_t t = 0;
  std::memcpy(&sub, m.second.data() + 1, 4);
  std::memcpy(&t, m.second.data() + 5, 8);
  EXPECT_EQ(sub, 7U);
  EXPECT_EQ(t, 123456789ULL);
  EXPECT_EQ(m.second.substr(13), "{\"x\":1}");
  c.send_text("{\"op\":\"unsubscribe\",\"subscriptionIds\":[7]}");
  ASSERT_TRUE(eventually([&] { return !(*server)->has_subscribers(2); }));
}

TEST(FoxgloveServer, AClientThatNeverReadsIsBoundedAndDoesNotStallOthers) {
  const std::size_t max_queue = 1 << 20;
  auto server = FoxgloveServer::create(0, two_channels(), false, max_queue);
  ASSERT_TRUE(server.ok());
  RawClient stuck((*server)->port(), true);
  ASSERT_TRUE(stuck.handshake());
  stuck.send_text("{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":1,\"channelId\":1}]}");
  RawClient reader((*server)->port());
  ASSERT_TRUE(reader.handshake());
  reader.send_text("{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":1,\"channelId\":1}]}");
  ASSERT_TRUE(eventually([&] { return (*server)->stats().clients_now == 2 && (*server)->has_subscribers(1); }));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // both subscriptions are in
  const std::string big(100000, 'x');
  int received = 0;
  (void)reader.next();  // serverInfo
  (void)reader.next();  // advertise
  for (int i = 0; i < 400; ++i) {  // 40 MB to the stuck client
    (*server)->publish(1, static_cast<std::uint64_t>(i), big);
    auto m = reader.next();
    if (m.first == 2) ++received;
  }
  const ServerStats s = (*server)->stats();
  EXPECT_EQ(received, 400);
  EXPECT_LE(s.queued_bytes, max_queue + big.size() + 64);
  EXPECT_GT(s.messages_dropped, 200U);  // the rest sits in the kernel's socket buffers
}

TEST(FoxgloveServer, SurvivesTenConnectDisconnectCycles) {
  auto server = FoxgloveServer::create(0, two_channels());
  ASSERT_TRUE(server.ok());
  for (int i = 0; i < 10; ++i) {
    RawClient c((*server)->port());
    ASSERT_TRUE(c.handshake());
    c.send_text("{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":3,\"channelId\":1}]}");
    (*server)->publish(1, 1, "{}");
  }
  ASSERT_TRUE(eventually([&] { return (*server)->stats().clients_now == 0; }));
  EXPECT_EQ((*server)->stats().clients_accepted, 10U);
  RawClient last((*server)->port());
  ASSERT_TRUE(last.handshake());
  EXPECT_NE(last.next().second.find("serverInfo"), std::string::npos);
}

}  // namespace
