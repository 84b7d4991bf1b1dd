// Messages over TCP, framed as the robot controller's two services frame them:
// - the command service (JSON-RPC 2.0): bare JSON objects back to back, no length and no delimiter. We send
//   compact objects as they are; we read objects by their braces (strings and escapes respected).
// - the state service (RTDE): each message in a SOF frame: the bytes 'S' 'O' 'F', a version byte, the
//   payload's length as a big-endian 16-bit number, then the payload (at most 65535 bytes).
// Every wait has a timeout; a peer that closes or resets the connection is a LinkError.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>

namespace weldtwin {

/// The connection is gone (closed, reset, or could not be made) or a wait timed out where it must not.
class LinkError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Splits a byte stream into top-level JSON objects.
class JsonFramer {
 public:
  void feed(const char* data, size_t n);
  /// The next whole object's text; false when more bytes are needed. Bytes outside objects (newlines,
  /// spaces, garbage) are skipped. Brackets are counted, not matched: `{"a":1]` comes out as one text, which
  /// the JSON parser then refuses.
  bool next(std::string& object);
  /// Bytes held for an object not yet complete (bounded by the caller: a peer that never closes one).
  size_t pending() const { return buf_.size() - start_; }

 private:
  std::string buf_;
  size_t start_ = 0, scan_ = 0;
  int depth_ = 0;
  bool in_string_ = false, escape_ = false;
};

/// Splits a byte stream into SOF frames' payloads. Bytes before a frame's 'S' 'O' 'F' (garbage, a frame cut
/// off) are skipped; a frame whose length runs past what came so far waits for more.
class SofFramer {
 public:
  static constexpr size_t kHeaderBytes = 6;
  static constexpr size_t kMaxPayloadBytes = 65535;
  void feed(const char* data, size_t n);
  /// The next whole frame's payload (and its version byte); false when more bytes are needed.
  bool next(std::string& payload, unsigned char* version = nullptr);
  size_t pending() const { return buf_.size() - start_; }

 private:
  std::string buf_;
  size_t start_ = 0;
};

/// A payload in a SOF frame. Throws std::length_error above 65535 bytes.
std::string sof_frame(const std::string& payload, unsigned char version);

/// How a connection's messages are framed.
enum class Framing {
  kJsonObjects,  ///< the command service: bare JSON objects
  kSofFrames,    ///< the state service: SOF frames
};

/// The version byte we put in the SOF frames we send.
constexpr unsigned char kSofVersion = 1;

/// One TCP connection carrying framed messages. Move-only; closes on destruction.
class JsonLink {
 public:
  /// Connects to host:port within `timeout_s`. Throws LinkError naming host:port and the reason.
  static JsonLink connect(const std::string& host, int port, double timeout_s,
                          Framing framing = Framing::kJsonObjects);
  explicit JsonLink(int fd = -1, Framing framing = Framing::kJsonObjects) : fd_(fd), framing_(framing) {}
  JsonLink(JsonLink&& o) noexcept;
  JsonLink& operator=(JsonLink&& o) noexcept;
  JsonLink(const JsonLink&) = delete;
  JsonLink& operator=(const JsonLink&) = delete;
  ~JsonLink() { close(); }

  /// Sends one message (a JSON text as it is, or a payload in a SOF frame). Throws LinkError when the peer
  /// is gone or does not take it in `timeout_s`.
  void send(const std::string& message, double timeout_s = 2.0);
  /// Sends bytes as they are (the tests' fake controller sending garbage).
  void send_raw(const std::string& bytes, double timeout_s = 2.0);
  /// The next message (an object's text, or a frame's payload), waiting up to `timeout_s`; nullopt when none
  /// came in time. Throws LinkError when the peer closed the connection (or sent 16 MB without a whole
  /// message).
  std::optional<std::string> receive(double timeout_s);
  void close();
  bool is_open() const { return fd_ >= 0; }

 private:
  bool next_message(std::string& message);

  int fd_ = -1;
  Framing framing_ = Framing::kJsonObjects;
  JsonFramer json_;
  SofFramer sof_;
};

/// A listening socket on 127.0.0.1 (the tests' fake controller). Port 0: the system picks one.
class JsonListener {
 public:
  explicit JsonListener(int port = 0);
  ~JsonListener();
  JsonListener(const JsonListener&) = delete;
  JsonListener& operator=(const JsonListener&) = delete;
  int port() const { return port_; }
  /// The next client, waiting up to `timeout_s`; nullopt when none came.
  std::optional<JsonLink> accept(double timeout_s, Framing framing = Framing::kJsonObjects);

 private:
  int fd_ = -1;
  int port_ = 0;
};

}  // namespace weldtwin
