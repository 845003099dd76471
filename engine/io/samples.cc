#include "engine/io/samples.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <map>
#include <type_traits>

#include "engine/check.h"
#include "engine/errors.h"

namespace hapvox::engine::io {
namespace {

const std::map<std::string, SampleTypeInfo>& sample_type_table() {
  static const auto* table = [] {
    auto* t = new std::map<std::string, SampleTypeInfo>;
    auto add = [t](SampleTypeInfo info, std::initializer_list<const char*> spellings) {
      for (const char* s : spellings) (*t)[s] = info;
    };
    add({SampleType::kInt8, "int8", 1}, {"signed char", "int8", "int8_t"});
    add({SampleType::kUint8, "uint8", 1}, {"uchar", "unsigned char", "uint8", "uint8_t"});
    add({SampleType::kInt16, "int16", 2},
        {"short", "short int", "signed short", "signed short int", "int16", "int16_t"});
    add({SampleType::kUint16, "uint16", 2},
        {"ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"});
    add({SampleType::kInt32, "int32", 4}, {"int", "signed int", "int32", "int32_t"});
    add({SampleType::kUint32, "uint32", 4}, {"uint", "unsigned int", "uint32", "uint32_t"});
    add({SampleType::kInt64, "int64", 8},
        {"longlong", "long long", "long long int", "signed long long", "signed long long int",
         "int64", "int64_t"});
    add({SampleType::kUint64, "uint64", 8},
        {"ulonglong", "unsigned long long", "unsigned long long int", "uint64", "uint64_t"});
    add({SampleType::kFloat, "float", 4}, {"float"});
    add({SampleType::kDouble, "double", 8}, {"double"});
    return t;
  }();
  return *table;
}

template <typename T>
T load_sample(const unsigned char* p, bool swap) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, p, sizeof(T));
  if (swap) std::reverse(bytes, bytes + sizeof(T));
  T v;
  std::memcpy(&v, bytes, sizeof(T));
  return v;
}

template <typename T>
void convert_samples(const std::vector<unsigned char>& bytes, bool swap, std::vector<float>* out,
                     const std::string& path) {
  const std::size_t n = out->size();
  bool non_finite = false;
  bool out_of_range = false;
  for (std::size_t i = 0; i < n; ++i) {
    const T v = load_sample<T>(bytes.data() + i * sizeof(T), swap);
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(v)) non_finite = true;
      if constexpr (sizeof(T) > sizeof(float)) {
        if (std::abs(v) > std::numeric_limits<float>::max()) out_of_range = true;
      }
    }
    (*out)[i] = static_cast<float>(v);
  }
  if (non_finite) throw InputError(path, "float data contains NaN or infinite values");
  if (out_of_range) throw InputError(path, "double data contains values beyond float range");
}

}  // namespace

const SampleTypeInfo* find_sample_type(const std::string& spelling) {
  const auto it = sample_type_table().find(spelling);
  return it == sample_type_table().end() ? nullptr : &it->second;
}

const SampleTypeInfo& sample_type_info(SampleType type) {
  for (const auto& [spelling, info] : sample_type_table()) {
    if (info.type == type) return info;
  }
  HAPVOX_CHECK(false);
  std::abort();
}

void decode_samples(const std::vector<unsigned char>& bytes, SampleType type, bool swap,
                    std::vector<float>* out, const std::string& path) {
  switch (type) {
    case SampleType::kInt8:
      convert_samples<std::int8_t>(bytes, swap, out, path);
      break;
    case SampleType::kUint8:
      convert_samples<std::uint8_t>(bytes, swap, out, path);
      break;
    case SampleType::kInt16:
      convert_samples<std::int16_t>(bytes, swap, out, path);
      break;
    case SampleType::kUint16:
      convert_samples<std::uint16_t>(bytes, swap, out, path);
      break;
    case SampleType::kInt32:
      convert_samples<std::int32_t>(bytes, swap, out, path);
      break;
    case SampleType::kUint32:
      convert_samples<std::uint32_t>(bytes, swap, out, path);
      break;
    case SampleType::kInt64:
      convert_samples<std::int64_t>(bytes, swap, out, path);
      break;
    case SampleType::kUint64:
      convert_samples<std::uint64_t>(bytes, swap, out, path);
      break;
    case SampleType::kFloat:
      convert_samples<float>(bytes, swap, out, path);
      break;
    case SampleType::kDouble:
      convert_samples<double>(bytes, swap, out, path);
      break;
  }
}

void set_min_max(RawVolume* raw) {
  if (raw->intensity.empty()) return;
  const auto [lo, hi] = std::minmax_element(raw->intensity.begin(), raw->intensity.end());
  raw->min_intensity = *lo;
  raw->max_intensity = *hi;
}

}  // namespace hapvox::engine::io
