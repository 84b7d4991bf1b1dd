#include "hw/mcap.hpp"

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "core/error.hpp"
#include "core/files.hpp"

namespace weldtwin::mcap {
namespace {

constexpr uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
enum Op : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kDataEnd = 0x0F,
};
constexpr uint64_t kMaxChunkBytes = 1ull << 30;  // a chunk's records, uncompressed (rosbag2 writes ~1 MB)
constexpr uint64_t kMaxLz4Ratio = 255;           // what one LZ4 byte can expand to, at most
constexpr uint64_t kMaxZstdRatio = 1000;         // beyond any sweep's messages (zstd's own bound is higher)
constexpr size_t kWriteChunkBytes = 1u << 20;

/// Bytes read from the front, every length checked against what is left.
class Cursor {
 public:
  Cursor(const uint8_t* p, size_t n, const std::string& file, const char* where)
      : p_(p), n_(n), file_(file), where_(where) {}
  size_t left() const { return n_ - pos_; }
  bool done() const { return pos_ == n_; }
  const uint8_t* here() const { return p_ + pos_; }
  template <typename T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, p_ + pos_, sizeof(T));  // MCAP is little-endian, as every host weldtwin runs on
    pos_ += sizeof(T);
    return v;
  }
  std::string str() {
    const uint32_t len = get<uint32_t>();
    need(len);
    std::string s(reinterpret_cast<const char*>(p_ + pos_), len);
    pos_ += len;
    return s;
  }
  void skip(uint64_t k) {
    need(k);
    pos_ += static_cast<size_t>(k);
  }
  void need(uint64_t k) const {
    if (k > left())
      throw input_error(file_, std::string("MCAP: ") + where_ + " runs past its end (truncated or corrupt)");
  }

 private:
  const uint8_t* p_;
  size_t n_, pos_ = 0;
  const std::string& file_;
  const char* where_;
};

struct Reader {
  const std::string& file;
  File out;
  std::map<uint16_t, Channel> schemas;  // by schema id: name, encoding, text
  bool data_ended = false, footer = false;

  void records(Cursor& c, bool in_chunk) {
    while (!c.done() && !data_ended) {
      const uint8_t op = c.get<uint8_t>();
      const uint64_t len = c.get<uint64_t>();
      c.need(len);
      Cursor body(c.here(), static_cast<size_t>(len), file, record_name(op));
      c.skip(len);
      if (in_chunk && op != kSchema && op != kChannel && op != kMessage)
        throw input_error(file, std::string("MCAP: a chunk holds a ") + record_name(op) + " record");
      switch (op) {
        case kSchema:
          schema(body);
          break;
        case kChannel:
          channel(body);
          break;
        case kMessage:
          message(body);
          break;
        case kChunk:
          chunk(body);
          break;
        case kDataEnd:
          data_ended = true;
          break;
        case kFooter:  // a writer that left out the data-end record
          if (!c.done()) throw input_error(file, "MCAP: records after the footer");
          footer = data_ended = true;
          break;
        case kHeader:
          throw input_error(file, "MCAP: a second header");
        default:
          break;  // indexes, attachments, metadata, statistics: nothing a sweep needs
      }
    }
  }

  static const char* record_name(uint8_t op) {
    switch (op) {
      case kHeader:
        return "header";
      case kFooter:
        return "footer";
      case kSchema:
        return "schema";
      case kChannel:
        return "channel";
      case kMessage:
        return "message";
      case kChunk:
        return "chunk";
      case kDataEnd:
        return "data end";
      default:
        return "record";
    }
  }

  void schema(Cursor& c) {
    const uint16_t id = c.get<uint16_t>();
    Channel s;
    s.schema_name = c.str();
    s.schema_encoding = c.str();
    s.schema_text = c.str();
    if (id != 0) schemas[id] = std::move(s);  // id 0 is no schema
  }

  void channel(Cursor& c) {
    Channel ch;
    ch.id = c.get<uint16_t>();
    const uint16_t schema_id = c.get<uint16_t>();
    ch.topic = c.str();
    ch.message_encoding = c.str();
    c.skip(c.get<uint32_t>());  // metadata (a map: its byte length, then key and value strings)
    if (schema_id != 0) {
      const auto it = schemas.find(schema_id);
      if (it == schemas.end())
        throw input_error(file, "MCAP: channel '" + ch.topic + "' names schema " + std::to_string(schema_id) +
                                    ", which comes nowhere before it");
      ch.schema_name = it->second.schema_name;
      ch.schema_encoding = it->second.schema_encoding;
      ch.schema_text = it->second.schema_text;
    }
    out.channels[ch.id] = std::move(ch);
  }

  void message(Cursor& c) {
    Message m;
    m.channel = c.get<uint16_t>();
    c.get<uint32_t>();  // sequence
    m.log_time_ns = c.get<uint64_t>();
    c.get<uint64_t>();  // publish time
    if (!out.channels.count(m.channel))
      throw input_error(file,
                        "MCAP: a message on channel " + std::to_string(m.channel) + ", which is not defined");
    m.data.assign(c.here(), c.here() + c.left());
    out.messages.push_back(std::move(m));
  }

  void chunk(Cursor& c) {
    c.get<uint64_t>();  // message start time
    c.get<uint64_t>();  // message end time
    const uint64_t size = c.get<uint64_t>();
    const uint32_t crc = c.get<uint32_t>();
    const std::string compression = c.str();
    const uint64_t stored = c.get<uint64_t>();
    c.need(stored);
    const uint8_t* data = c.here();
    if (size > kMaxChunkBytes)
      throw input_error(file,
                        "MCAP: a chunk of " + std::to_string(size) + " bytes uncompressed (at most 1 GiB)");
    std::vector<uint8_t> plain;
    if (compression.empty()) {
      if (stored != size) throw input_error(file, "MCAP: an uncompressed chunk whose sizes differ");
      plain.assign(data, data + stored);
    } else if (compression == "zstd") {
      if (size > kMaxZstdRatio * stored + 64)
        throw input_error(file, "MCAP: a zstd chunk claims " + std::to_string(size) + " bytes from " +
                                    std::to_string(stored));
      plain.resize(static_cast<size_t>(size));
      const size_t got = ZSTD_decompress(plain.data(), plain.size(), data, static_cast<size_t>(stored));
      if (ZSTD_isError(got) || got != size)
        throw input_error(file, std::string("MCAP: a zstd chunk does not decompress to its size (") +
                                    (ZSTD_isError(got) ? ZSTD_getErrorName(got) : "short") + ")");
    } else if (compression == "lz4") {
      if (size > kMaxLz4Ratio * stored + 64)
        throw input_error(file, "MCAP: an lz4 chunk claims " + std::to_string(size) + " bytes from " +
                                    std::to_string(stored));
      plain.resize(static_cast<size_t>(size));
      LZ4F_dctx* ctx = nullptr;
      if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION)))
        throw std::runtime_error("LZ4F_createDecompressionContext failed");
      size_t out_size = plain.size(), in_size = static_cast<size_t>(stored);
      const size_t rc = LZ4F_decompress(ctx, plain.data(), &out_size, data, &in_size, nullptr);
      LZ4F_freeDecompressionContext(ctx);
      if (LZ4F_isError(rc) || rc != 0 || out_size != size)
        throw input_error(file, "MCAP: an lz4 chunk does not decompress to its size");
    } else {
      throw input_error(file,
                        "MCAP: chunks compressed as '" + compression + "' (weldtwin reads none, lz4, zstd)");
    }
    if (crc != 0 && crc32(0L, plain.data(), static_cast<uInt>(plain.size())) != crc)
      throw input_error(file, "MCAP: a chunk whose CRC does not match its records (corrupt)");
    Cursor inner(plain.data(), plain.size(), file, "a record in a chunk");
    records(inner, true);
  }
};

// --- writing ---

class Out {
 public:
  template <typename T>
  void put(T v) {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    b_.insert(b_.end(), p, p + sizeof(T));
  }
  void str(const std::string& s) {
    put<uint32_t>(static_cast<uint32_t>(s.size()));
    b_.insert(b_.end(), s.begin(), s.end());
  }
  void bytes(const std::vector<uint8_t>& v) { b_.insert(b_.end(), v.begin(), v.end()); }
  void record(uint8_t op, const Out& body) {
    put<uint8_t>(op);
    put<uint64_t>(body.b_.size());
    bytes(body.b_);
  }
  const std::vector<uint8_t>& data() const { return b_; }
  size_t size() const { return b_.size(); }
  void clear() { b_.clear(); }

 private:
  std::vector<uint8_t> b_;
};

}  // namespace

File read(const std::string& path) {
  if (!is_file(path)) throw input_error(path, "no such file");
  std::ifstream in(path, std::ios::binary);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    throw input_error(path, "not an MCAP file (no MCAP magic)");
  if (bytes.size() < 16 + 9 + 20 || std::memcmp(bytes.data() + bytes.size() - 8, kMagic, 8) != 0)
    throw input_error(path,
                      "MCAP: no closing magic: the recording was cut short (its recorder did not close it)");
  Reader r{path, {}, {}, false, false};
  Cursor c(bytes.data() + 8, bytes.size() - 16, path, "the file");
  if (c.get<uint8_t>() != kHeader) throw input_error(path, "MCAP: no header record");
  const uint64_t header_len = c.get<uint64_t>();
  c.need(header_len);
  Cursor header(c.here(), static_cast<size_t>(header_len), path, "the header");
  r.out.profile = header.str();
  c.skip(header_len);
  r.records(c, false);
  if (r.footer) return std::move(r.out);
  // After the data section: the summary (skipped), then the footer last.
  while (!c.done()) {
    const uint8_t op = c.get<uint8_t>();
    const uint64_t len = c.get<uint64_t>();
    c.skip(len);
    if (op == kFooter) {
      if (!c.done()) throw input_error(path, "MCAP: records after the footer");
      return std::move(r.out);
    }
  }
  throw input_error(path, "MCAP: no footer record");
}

void write(const std::string& path, const File& file) {
  Out o, body;
  o.bytes(std::vector<uint8_t>(kMagic, kMagic + 8));
  body.str(file.profile);
  body.str("weldtwin");
  o.record(kHeader, body);
  uint16_t schema_id = 0;
  for (const auto& [id, ch] : file.channels) {
    uint16_t sid = 0;
    if (!ch.schema_name.empty()) {
      sid = ++schema_id;
      body.clear();
      body.put<uint16_t>(sid);
      body.str(ch.schema_name);
      body.str(ch.schema_encoding);
      body.str(ch.schema_text);
      o.record(kSchema, body);
    }
    body.clear();
    body.put<uint16_t>(id);
    body.put<uint16_t>(sid);
    body.str(ch.topic);
    body.str(ch.message_encoding);
    body.put<uint32_t>(0);  // no metadata
    o.record(kChannel, body);
  }
  Out chunk;
  uint64_t t_first = 0, t_last = 0;
  uint32_t sequence = 0;
  auto flush = [&] {
    if (chunk.size() == 0) return;
    body.clear();
    body.put<uint64_t>(t_first);
    body.put<uint64_t>(t_last);
    body.put<uint64_t>(chunk.size());
    body.put<uint32_t>(
        static_cast<uint32_t>(crc32(0L, chunk.data().data(), static_cast<uInt>(chunk.size()))));
    body.str("");
    body.put<uint64_t>(chunk.size());
    body.bytes(chunk.data());
    o.record(kChunk, body);
    chunk.clear();
  };
  for (const Message& m : file.messages) {
    if (chunk.size() == 0) t_first = t_last = m.log_time_ns;
    t_first = std::min(t_first, m.log_time_ns);
    t_last = std::max(t_last, m.log_time_ns);
    body.clear();
    body.put<uint16_t>(m.channel);
    body.put<uint32_t>(++sequence);
    body.put<uint64_t>(m.log_time_ns);
    body.put<uint64_t>(m.log_time_ns);
    body.bytes(m.data);
    chunk.record(kMessage, body);
    if (chunk.size() >= kWriteChunkBytes) flush();
  }
  flush();
  body.clear();
  body.put<uint32_t>(0);  // no data section CRC
  o.record(kDataEnd, body);
  body.clear();
  body.put<uint64_t>(0);  // no summary
  body.put<uint64_t>(0);
  body.put<uint32_t>(0);
  o.record(kFooter, body);
  o.bytes(std::vector<uint8_t>(kMagic, kMagic + 8));
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(o.data().data()), static_cast<std::streamsize>(o.size()));
  if (!f.flush()) throw std::runtime_error(path + ": cannot write the MCAP file");
}

}  // namespace weldtwin::mcap
