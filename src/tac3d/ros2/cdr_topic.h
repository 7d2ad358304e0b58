#pragma once

// Cyclone DDS topics whose samples are CDR bytes made elsewhere (tac3d/mcap/ros2_messages.h): a
// minimal ddsi_sertype that hands the bytes to Cyclone as they are, so that a sample on the wire
// and a message in an MCAP file come from the one encoder. Internal to the ros2 module.

#include <dds/dds.h>

#include <cstdint>
#include <string>
#include <vector>

struct ddsi_sertype;

namespace tac3d::internal {

/// A topic made by CreateCdrTopic: the entity, and the type its samples carry.
struct CdrTopic {
  dds_entity_t topic = 0;
  const ddsi_sertype* type = nullptr;
};

/// Creates the topic `name` of the keyless DDS type `type_name`
/// ("geometry_msgs::msg::dds_::WrenchStamped_") whose samples are written with WriteCdr.
/// @return the topic, or one whose `topic` is the negative DDS return code.
CdrTopic CreateCdrTopic(dds_entity_t participant, const std::string& name, const std::string& type_name);

/// Writes `cdr`, a sample in classic CDR after its 4-byte encapsulation header (CdrWriter's), on
/// `writer`, a writer of `topic`.
/// @return DDS_RETCODE_OK, or the negative code dds_writecdr gave (a timeout of a reliable
///   writer whose reader lags, say).
dds_return_t WriteCdr(dds_entity_t writer, const CdrTopic& topic, std::vector<std::uint8_t> cdr);

}  // namespace tac3d::internal
