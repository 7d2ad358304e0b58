#include "tac3d/ros2/cdr_topic.h"

#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <new>

namespace tac3d::internal {
namespace {

// A sample: its CDR bytes, zero-padded to a multiple of 4 (Cyclone reads up to the next multiple
// of 4 past its size; RTPS submessages are 4-byte aligned).
struct CdrSerdata {
  ddsi_serdata c;  // first: Cyclone's pointer is this one's
  std::vector<std::uint8_t> bytes;
  std::uint32_t size = 0;  // without the padding
};

CdrSerdata* AsCdr(const ddsi_serdata* d) { return reinterpret_cast<CdrSerdata*>(const_cast<ddsi_serdata*>(d)); }

CdrSerdata* NewSerdata(const ddsi_sertype* type, ddsi_serdata_kind kind, std::vector<std::uint8_t> bytes) {
  auto* d = new CdrSerdata{};
  ddsi_serdata_init(&d->c, type, kind);
  d->size = static_cast<std::uint32_t>(bytes.size());
  bytes.resize((bytes.size() + 3) / 4 * 4, 0);
  d->bytes = std::move(bytes);
  return d;
}

// Keyless: every sample is of the one instance.
bool EqKey(const ddsi_serdata*, const ddsi_serdata*) { return true; }
std::uint32_t Size(const ddsi_serdata* d) { return AsCdr(d)->size; }
void Free(ddsi_serdata* d) { delete AsCdr(d); }

// Samples received from the network are never made: these topics are only written.
ddsi_serdata* FromSer(const ddsi_sertype*, ddsi_serdata_kind, const nn_rdata*, size_t) { return nullptr; }

ddsi_serdata* FromSerIov(const ddsi_sertype* type, ddsi_serdata_kind kind, ddsrt_msg_iovlen_t niov,
                         const ddsrt_iovec_t* iov, size_t size) {
  std::vector<std::uint8_t> bytes;
  bytes.reserve(size);
  for (ddsrt_msg_iovlen_t i = 0; i < niov; ++i) {
    const auto* p = static_cast<const std::uint8_t*>(iov[i].iov_base);
    bytes.insert(bytes.end(), p, p + iov[i].iov_len);
  }
  bytes.resize(size);
  return &NewSerdata(type, kind, std::move(bytes))->c;
}

ddsi_serdata* FromKeyhash(const ddsi_sertype* type, const ddsi_keyhash*) {
  return &NewSerdata(type, SDK_KEY, {})->c;
}

// A sample of these topics is a std::vector<std::uint8_t> of CDR bytes.
ddsi_serdata* FromSample(const ddsi_sertype* type, ddsi_serdata_kind kind, const void* sample) {
  return &NewSerdata(type, kind, *static_cast<const std::vector<std::uint8_t>*>(sample))->c;
}

void ToSer(const ddsi_serdata* d, size_t off, size_t sz, void* buf) {
  std::memcpy(buf, AsCdr(d)->bytes.data() + off, sz);
}

ddsi_serdata* ToSerRef(const ddsi_serdata* d, size_t off, size_t sz, ddsrt_iovec_t* ref) {
  ref->iov_base = AsCdr(d)->bytes.data() + off;
  ref->iov_len = static_cast<ddsrt_iov_len_t>(sz);
  return ddsi_serdata_ref(d);
}

void ToSerUnref(ddsi_serdata* d, const ddsrt_iovec_t*) { ddsi_serdata_unref(d); }

bool ToSample(const ddsi_serdata* d, void* sample, void**, void*) {
  const CdrSerdata* s = AsCdr(d);
  static_cast<std::vector<std::uint8_t>*>(sample)->assign(s->bytes.begin(), s->bytes.begin() + s->size);
  return true;
}

ddsi_serdata* ToUntyped(const ddsi_serdata* d) { return &NewSerdata(d->type, SDK_KEY, {})->c; }
bool UntypedToSample(const ddsi_sertype*, const ddsi_serdata*, void*, void**, void*) { return true; }

size_t Print(const ddsi_sertype*, const ddsi_serdata* d, char* buf, size_t size) {
  return static_cast<size_t>(std::snprintf(buf, size, "(%u bytes of CDR)", AsCdr(d)->size));
}

void GetKeyhash(const ddsi_serdata*, ddsi_keyhash* buf, bool) { std::memset(buf, 0, sizeof(*buf)); }

const ddsi_serdata_ops kSerdataOps = {
    .eqkey = EqKey,
    .get_size = Size,
    .from_ser = FromSer,
    .from_ser_iov = FromSerIov,
    .from_keyhash = FromKeyhash,
    .from_sample = FromSample,
    .to_ser = ToSer,
    .to_ser_ref = ToSerRef,
    .to_ser_unref = ToSerUnref,
    .to_sample = ToSample,
    .to_untyped = ToUntyped,
    .untyped_to_sample = UntypedToSample,
    .free = Free,
    .print = Print,
    .get_keyhash = GetKeyhash,
#ifdef DDS_HAS_SHM
    .get_sample_size = nullptr,  // no shared memory (iceoryx) for these topics
    .from_iox_buffer = nullptr,
#endif
};

void FreeType(ddsi_sertype* type) {
  ddsi_sertype_fini(type);
  delete type;
}

void ZeroSamples(const ddsi_sertype*, void* samples, size_t count) {
  auto* s = static_cast<std::vector<std::uint8_t>*>(samples);
  for (size_t i = 0; i < count; ++i) s[i].clear();
}

// Samples are only ever passed in by the caller (WriteCdr); Cyclone never allocates any.
void ReallocSamples(void** ptrs, const ddsi_sertype*, void*, size_t, size_t count) {
  std::fill(ptrs, ptrs + count, nullptr);
}
void FreeSamples(const ddsi_sertype*, void**, size_t, dds_free_op_t) {}

// Two of these types with one name are the same type.
bool Equal(const ddsi_sertype*, const ddsi_sertype*) { return true; }
std::uint32_t Hash(const ddsi_sertype*) { return 0; }

const ddsi_sertype_ops kSertypeOps = {
    .version = ddsi_sertype_v0,
    .arg = nullptr,
    .free = FreeType,
    .zero_samples = ZeroSamples,
    .realloc_samples = ReallocSamples,
    .free_samples = FreeSamples,
    .equal = Equal,
    .hash = Hash,
    .type_id = nullptr,
    .type_map = nullptr,
    .type_info = nullptr,
    .derive_sertype = nullptr,
    .get_serialized_size = nullptr,
    .serialize_into = nullptr,
};

}  // namespace

CdrTopic CreateCdrTopic(dds_entity_t participant, const std::string& name, const std::string& type_name) {
  auto* type = new ddsi_sertype{};
  ddsi_sertype_init_flags(type, type_name.c_str(), &kSertypeOps, &kSerdataOps, DDSI_SERTYPE_FLAG_TOPICKIND_NO_KEY);
  ddsi_sertype* used = type;
  const dds_entity_t topic = dds_create_topic_sertype(participant, name.c_str(), &used, nullptr, nullptr, nullptr);
  if (topic < 0) {
    ddsi_sertype_unref(type);
    return {topic, nullptr};
  }
  return {topic, used};
}

dds_return_t WriteCdr(dds_entity_t writer, const CdrTopic& topic, std::vector<std::uint8_t> cdr) {
  // dds_writecdr takes over the reference.
  return dds_writecdr(writer, &NewSerdata(topic.type, SDK_DATA, std::move(cdr))->c);
}

}  // namespace tac3d::internal
