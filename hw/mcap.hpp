// MCAP, the container rosbag2 records in by default (its "mcap" storage), read and written by weldtwin's
// own code after the published format: magic `\x89MCAP0\r\n`, then records of one opcode byte, a
// little-endian u64 length and the content; strings and byte arrays carry a u32 length, maps a u32 byte
// length. The reader walks the data section in order (Schema, Channel, Message records, and Chunks holding
// them: uncompressed, "lz4" frames or "zstd"), checks every length against what holds it, a chunk's
// uncompressed size against its compressed one (at most 1 GiB, and what the codec can expand to) and its CRC
// where one is given, and skips the records it has no use for (indexes, attachments, metadata, statistics,
// the summary). The writer writes one uncompressed chunk per 1 MB of messages, with a data-end record and
// no summary (a summary is optional in the format).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace weldtwin::mcap {

struct Channel {
  uint16_t id = 0;
  std::string topic, message_encoding;  ///< e.g. "/scan", "cdr"
  std::string schema_name;              ///< the message type, e.g. "sensor_msgs/msg/LaserScan" ("" if none)
  std::string schema_encoding;          ///< e.g. "ros2msg"
  std::string schema_text;              ///< the schema's data (a message definition, for ros2msg)
};

struct Message {
  uint16_t channel = 0;
  uint64_t log_time_ns = 0;
  std::vector<uint8_t> data;
};

struct File {
  std::string profile;  ///< the header's, e.g. "ros2"
  std::map<uint16_t, Channel> channels;
  std::vector<Message> messages;  ///< in file order
};

/// Reads `path`. Throws InputError naming the file and the problem (not MCAP, a record past the end of what
/// holds it, a message on an unknown channel, a chunk that does not decompress to its size or CRC, ...).
File read(const std::string& path);

/// Writes `file` (profile, channels with their schemas, messages). Throws std::runtime_error when it cannot.
void write(const std::string& path, const File& file);

}  // namespace weldtwin::mcap
