#include "dds/topics.hpp"

namespace cobridge::dds {

std::string topic_name(std::string_view prefix, std::string_view topic) {
  std::string name(prefix);
  name += topic;
  return name;
}

Qos encoder_sample_writer_qos(Reliability reliability, int32_t depth, dds_duration_t lease,
                              dds_duration_t max_blocking) {
  Qos q(dds_create_qos());
  dds_qset_liveliness(q.get(), DDS_LIVELINESS_AUTOMATIC, lease);
  dds_qset_reliability(q.get(),
                       reliability == Reliability::kReliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       max_blocking);
  dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, depth);
  dds_qset_durability(q.get(), DDS_DURABILITY_VOLATILE);
  return q;
}

Qos encoder_event_writer_qos(dds_duration_t lease) {
  Qos q(dds_create_qos());
  dds_qset_liveliness(q.get(), DDS_LIVELINESS_AUTOMATIC, lease);
  dds_qset_reliability(q.get(), DDS_RELIABILITY_RELIABLE, kMaxBlocking);
  dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, kEventDepth);
  dds_qset_durability(q.get(), DDS_DURABILITY_VOLATILE);
  return q;
}

Qos device_status_writer_qos(dds_duration_t lease) {
  Qos q(dds_create_qos());
  dds_qset_liveliness(q.get(), DDS_LIVELINESS_AUTOMATIC, lease);
  dds_qset_reliability(q.get(), DDS_RELIABILITY_RELIABLE, kMaxBlocking);
  dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(q.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
  return q;
}

Qos gateway_status_writer_qos(dds_duration_t lease) { return device_status_writer_qos(lease); }

Qos partition_qos(const std::string& partition) {
  Qos q(dds_create_qos());
  if (!partition.empty()) dds_qset_partition1(q.get(), partition.c_str());
  return q;
}

Qos gateway_status_reader_qos() {
  Qos q(dds_create_qos());
  dds_qset_reliability(q.get(), DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(q.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_ignorelocal(q.get(), DDS_IGNORELOCAL_PARTICIPANT);
  return q;
}

void set_exclusive(dds_qos_t* qos, std::int32_t strength) {
  dds_qset_ownership(qos, DDS_OWNERSHIP_EXCLUSIVE);
  dds_qset_ownership_strength(qos, strength);
}

}  // namespace cobridge::dds
