#include "hw/json_link.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

namespace weldtwin {
namespace {

constexpr size_t kMaxObjectBytes = 16u << 20;

int poll_ms(double timeout_s) {
  return timeout_s <= 0 ? 0 : static_cast<int>(timeout_s * 1000.0 + 0.999);
}

}  // namespace

// --- framing ---

void JsonFramer::feed(const char* data, size_t n) {
  if (start_ > 0 && start_ == buf_.size()) {  // everything consumed: start over
    buf_.clear();
    start_ = scan_ = 0;
  } else if (start_ > (1u << 16)) {  // keep the buffer compact
    buf_.erase(0, start_);
    scan_ -= start_;
    start_ = 0;
  }
  buf_.append(data, n);
}

bool JsonFramer::next(std::string& object) {
  for (; scan_ < buf_.size(); ++scan_) {
    const char c = buf_[scan_];
    if (depth_ == 0) {
      if (c != '{') {  // between objects: whitespace (or garbage) is skipped
        start_ = scan_ + 1;
        continue;
      }
      start_ = scan_;
      depth_ = 1;
      continue;
    }
    if (in_string_) {
      if (escape_)
        escape_ = false;
      else if (c == '\\')
        escape_ = true;
      else if (c == '"')
        in_string_ = false;
      continue;
    }
    if (c == '"') {
      in_string_ = true;
    } else if (c == '{' || c == '[') {
      ++depth_;
    } else if (c == '}' || c == ']') {
      if (--depth_ == 0) {
        object.assign(buf_, start_, scan_ + 1 - start_);
        start_ = ++scan_;
        return true;
      }
    }
  }
  return false;
}

void SofFramer::feed(const char* data, size_t n) {
  if (start_ > (1u << 16)) {  // keep the buffer compact
    buf_.erase(0, start_);
    start_ = 0;
  }
  buf_.append(data, n);
}

bool SofFramer::next(std::string& payload, unsigned char* version) {
  const size_t sof = buf_.find("SOF", start_);
  if (sof == std::string::npos) {  // no frame begins here: keep only what may be the start of one
    start_ = buf_.size() - std::min<size_t>(2, buf_.size() - start_);
    return false;
  }
  start_ = sof;
  if (buf_.size() - start_ < kHeaderBytes) return false;
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(buf_[start_ + k]); };
  const size_t length = (size_t{byte(4)} << 8) | byte(5);
  if (buf_.size() - start_ < kHeaderBytes + length) return false;
  if (version) *version = byte(3);
  payload.assign(buf_, start_ + kHeaderBytes, length);
  start_ += kHeaderBytes + length;
  return true;
}

std::string sof_frame(const std::string& payload, unsigned char version) {
  if (payload.size() > SofFramer::kMaxPayloadBytes)
    throw std::length_error("a state-service message of " + std::to_string(payload.size()) +
                            " bytes (a SOF frame holds at most 65535)");
  std::string f = "SOF";
  f += static_cast<char>(version);
  f += static_cast<char>(payload.size() >> 8);
  f += static_cast<char>(payload.size() & 0xff);
  return f + payload;
}

// --- connection ---

JsonLink::JsonLink(JsonLink&& o) noexcept
    : fd_(o.fd_), framing_(o.framing_), json_(std::move(o.json_)), sof_(std::move(o.sof_)) {
  o.fd_ = -1;
}

JsonLink& JsonLink::operator=(JsonLink&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    framing_ = o.framing_;
    json_ = std::move(o.json_);
    sof_ = std::move(o.sof_);
    o.fd_ = -1;
  }
  return *this;
}

void JsonLink::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

JsonLink JsonLink::connect(const std::string& host, int port, double timeout_s, Framing framing) {
  const std::string where = host + ":" + std::to_string(port);
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  if (getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &res) != 0 || !res)
    throw LinkError(where + ": unknown host");
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    freeaddrinfo(res);
    throw LinkError(where + ": " + std::strerror(errno));
  }
  const int r = ::connect(fd, res->ai_addr, res->ai_addrlen);
  freeaddrinfo(res);
  if (r != 0 && errno != EINPROGRESS) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw LinkError(where + ": cannot connect: " + why);
  }
  if (r != 0) {
    pollfd p{fd, POLLOUT, 0};
    if (poll(&p, 1, poll_ms(timeout_s)) <= 0) {
      ::close(fd);
      throw LinkError(where + ": no answer to the connection within " +
                      std::to_string(timeout_s).substr(0, 4) + " s");
    }
    int err = 0;
    socklen_t len = sizeof err;
    getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
    if (err != 0) {
      ::close(fd);
      throw LinkError(where + ": cannot connect: " + std::strerror(err));
    }
  }
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return JsonLink(fd, framing);
}

void JsonLink::send(const std::string& message, double timeout_s) {
  send_raw(framing_ == Framing::kSofFrames ? sof_frame(message, kSofVersion) : message, timeout_s);
}

void JsonLink::send_raw(const std::string& msg, double timeout_s) {
  if (fd_ < 0) throw LinkError("the connection is closed");
  const auto t0 = std::chrono::steady_clock::now();
  size_t off = 0;
  while (off < msg.size()) {
    const ssize_t n = ::send(fd_, msg.data() + off, msg.size() - off, MSG_NOSIGNAL);
    if (n > 0) {
      off += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)
      throw LinkError(std::string("the connection dropped: ") + std::strerror(errno));
    const double left =
        timeout_s - std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (left <= 0) throw LinkError("the peer does not take our message (send timed out)");
    pollfd p{fd_, POLLOUT, 0};
    poll(&p, 1, poll_ms(left));
  }
}

bool JsonLink::next_message(std::string& message) {
  return framing_ == Framing::kSofFrames ? sof_.next(message) : json_.next(message);
}

std::optional<std::string> JsonLink::receive(double timeout_s) {
  std::string object;
  if (next_message(object)) return object;
  if (fd_ < 0) throw LinkError("the connection is closed");
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    const double left =
        timeout_s - std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    pollfd p{fd_, POLLIN, 0};
    const int r = poll(&p, 1, poll_ms(left));
    if (r == 0) return std::nullopt;
    if (r < 0 && errno != EINTR) throw LinkError(std::string("poll failed: ") + std::strerror(errno));
    if (r < 0) continue;
    char buf[65536];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n == 0) throw LinkError("the connection was closed by the peer");
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
      throw LinkError(std::string("the connection dropped: ") + std::strerror(errno));
    }
    if (framing_ == Framing::kSofFrames)
      sof_.feed(buf, static_cast<size_t>(n));
    else
      json_.feed(buf, static_cast<size_t>(n));
    if (next_message(object)) return object;
    if (json_.pending() > kMaxObjectBytes) throw LinkError("16 MB without a whole JSON object");
  }
}

// --- listener ---

JsonListener::JsonListener(int port) {
  fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw LinkError(std::string("socket: ") + std::strerror(errno));
  const int one = 1;
  setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<uint16_t>(port));
  if (bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || listen(fd_, 4) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw LinkError("cannot listen on 127.0.0.1:" + std::to_string(port) + ": " + why);
  }
  socklen_t len = sizeof a;
  getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
}

JsonListener::~JsonListener() {
  if (fd_ >= 0) ::close(fd_);
}

std::optional<JsonLink> JsonListener::accept(double timeout_s, Framing framing) {
  pollfd p{fd_, POLLIN, 0};
  if (poll(&p, 1, poll_ms(timeout_s)) <= 0) return std::nullopt;
  const int fd = ::accept4(fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (fd < 0) return std::nullopt;
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return JsonLink(fd, framing);
}

}  // namespace weldtwin
