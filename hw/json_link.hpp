// JSON messages over TCP, as the robot controller's command (JSON-RPC 2.0) and state (RTDE) services speak
// them: every message is one JSON object. We write one object per line; we read objects by their braces
// (strings and escapes respected), so a peer that sends them back to back without newlines is read as well.
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

/// One TCP connection carrying JSON objects. Move-only; closes on destruction.
class JsonLink {
 public:
  /// Connects to host:port within `timeout_s`. Throws LinkError naming host:port and the reason.
  static JsonLink connect(const std::string& host, int port, double timeout_s);
  explicit JsonLink(int fd = -1) : fd_(fd) {}
  JsonLink(JsonLink&& o) noexcept;
  JsonLink& operator=(JsonLink&& o) noexcept;
  JsonLink(const JsonLink&) = delete;
  JsonLink& operator=(const JsonLink&) = delete;
  ~JsonLink() { close(); }

  /// Sends `text` and a newline. Throws LinkError when the peer is gone or does not take it in `timeout_s`.
  void send(const std::string& text, double timeout_s = 2.0);
  /// The next object, waiting up to `timeout_s`; nullopt when none came in time. Throws LinkError when the
  /// peer closed the connection (or sent 16 MB without closing an object).
  std::optional<std::string> receive(double timeout_s);
  void close();
  bool is_open() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
  JsonFramer framer_;
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
  std::optional<JsonLink> accept(double timeout_s);

 private:
  int fd_ = -1;
  int port_ = 0;
};

}  // namespace weldtwin
