// A small Foxglove WebSocket server (protocol "foxglove.websocket.v1", the live-data protocol of
// Foxglove Studio / Lichtblick) for `visnav run --view PORT`: RFC 6455 WebSocket over TCP, the
// server advertises its channels, clients subscribe, and each published message goes to every
// subscriber as a binary "message data" frame (opcode 1, subscription id, timestamp, payload).
//
// Threads: one server thread owns the sockets (accept, handshake, reads, writes; poll(2)).
// publish() may be called from any thread (the tick thread): it encodes the frame once and queues
// it for each subscriber. Bounded: a client whose queue holds more than max_queue_bytes loses
// the oldest messages of that client (a client that never reads cannot make the process grow),
// and a client that sends garbage or closes is dropped without affecting the others.
// Ownership: the destructor stops the thread and closes every socket.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::view {

struct ChannelInfo {
  std::string topic;
  std::string encoding = "json";          ///< message encoding
  std::string schema_name;                ///< e.g. "foxglove.CompressedImage"
  std::string schema;                     ///< the JSON schema text
  std::string schema_encoding = "jsonschema";
};

struct ServerStats {
  std::uint64_t clients_accepted = 0;
  std::uint64_t clients_now = 0;
  std::uint64_t messages_sent = 0;     ///< message frames handed to sockets
  std::uint64_t messages_dropped = 0;  ///< dropped from full client queues
  std::uint64_t queued_bytes = 0;      ///< bytes waiting in all client queues now
};

class FoxgloveServer {
 public:
  /// Listens on 127.0.0.1:`port` (0 = any free port; see port()) or on all interfaces when
  /// `all_interfaces`. Channels are fixed at creation.
  [[nodiscard]] static Result<std::unique_ptr<FoxgloveServer>> create(int port, std::vector<ChannelInfo> channels,
                                                                      bool all_interfaces = false,
                                                                      std::size_t max_queue_bytes = 8 << 20);
  ~FoxgloveServer();
  FoxgloveServer(const FoxgloveServer&) = delete;
  FoxgloveServer& operator=(const FoxgloveServer&) = delete;

  [[nodiscard]] int port() const { return port_; }
  /// Channel ids are 1..n in the order given to create().
  /// True if at least one client subscribes to `channel_id` (skip expensive encoding otherwise).
  [[nodiscard]] bool has_subscribers(std::uint32_t channel_id) const;
  /// Sends `payload` to every subscriber of `channel_id`, stamped `timestamp_ns`.
  void publish(std::uint32_t channel_id, std::uint64_t timestamp_ns, const std::string& payload);
  [[nodiscard]] ServerStats stats() const;

 private:
  struct Client {
    int fd = -1;
    bool handshaken = false;
    std::string in;                          // bytes received, not yet parsed
    std::deque<std::string> out;             // frames to send
    std::size_t out_front_sent = 0;          // bytes of out.front() already sent
    std::size_t out_bytes = 0;
    std::map<std::uint32_t, std::uint32_t> subscriptions;  // subscription id -> channel id
    bool closing = false;
  };
  FoxgloveServer() = default;
  void loop();
  void accept_clients();
  bool read_client(Client& c);   // false: drop
  bool write_client(Client& c);  // false: drop
  bool handle_frames(Client& c);
  bool handshake(Client& c);
  void handle_text(Client& c, const std::string& text);
  void enqueue(Client& c, std::string frame, bool droppable);
  void wake();

  int listen_fd_ = -1;
  int wake_fd_[2] = {-1, -1};
  int port_ = 0;
  std::size_t max_queue_bytes_ = 0;
  std::vector<ChannelInfo> channels_;
  mutable std::mutex mutex_;  // clients_, stats_
  std::map<int, Client> clients_;
  ServerStats stats_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// Helpers exposed for tests: SHA-1 digest and base64 (the WebSocket handshake).
[[nodiscard]] std::string sha1(const std::string& data);
[[nodiscard]] std::string base64(const std::string& data);
/// Escapes a string for a JSON string literal (without the quotes).
[[nodiscard]] std::string json_escape(const std::string& s);

}  // namespace visnav::view
