// A minimal protobuf wire-format reader and writer for the few ONNX fields the rewrites touch:
// ModelProto.graph (7); GraphProto.node (1) and input (11); NodeProto.input (1), output (2) and
// op_type (4); ValueInfoProto.name (1) and type (2). Every other field is copied byte for byte.
#include "onnx_graph.h"

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <vector>

namespace stillmap {
namespace {

struct Field {
  std::uint32_t number = 0;
  std::string raw;      // the whole field: key, length and payload
  std::string payload;  // length-delimited fields only
};

std::optional<std::uint64_t> ReadVarint(const std::string& bytes, size_t* at) {
  std::uint64_t value = 0;
  for (int shift = 0; shift < 64 && *at < bytes.size(); shift += 7) {
    const auto byte = static_cast<std::uint8_t>(bytes[(*at)++]);
    value |= static_cast<std::uint64_t>(byte & 0x7F) << shift;
    if ((byte & 0x80) == 0) return value;
  }
  return std::nullopt;
}

void WriteVarint(std::uint64_t value, std::string* out) {
  do {
    const auto byte = static_cast<std::uint8_t>(value & 0x7F);
    value >>= 7;
    out->push_back(static_cast<char>(value != 0 ? byte | 0x80 : byte));
  } while (value != 0);
}

// The fields of one message, or nothing when the bytes are not a well-formed message.
std::optional<std::vector<Field>> ReadFields(const std::string& bytes) {
  std::vector<Field> fields;
  size_t at = 0;
  while (at < bytes.size()) {
    const size_t start = at;
    const std::optional<std::uint64_t> key = ReadVarint(bytes, &at);
    if (!key) return std::nullopt;
    Field field;
    field.number = static_cast<std::uint32_t>(*key >> 3);
    switch (*key & 7) {
      case 0:  // varint
        if (!ReadVarint(bytes, &at)) return std::nullopt;
        break;
      case 1:  // 64-bit
        at += 8;
        break;
      case 5:  // 32-bit
        at += 4;
        break;
      case 2: {  // length-delimited
        const std::optional<std::uint64_t> length = ReadVarint(bytes, &at);
        if (!length || *length > bytes.size() - at) return std::nullopt;
        field.payload = bytes.substr(at, *length);
        at += *length;
        break;
      }
      default:  // groups (3, 4) are not used by ONNX
        return std::nullopt;
    }
    if (at > bytes.size()) return std::nullopt;
    field.raw = bytes.substr(start, at - start);
    fields.push_back(std::move(field));
  }
  return fields;
}

std::string Varint(std::uint32_t number, std::uint64_t value) {
  std::string out;
  WriteVarint(static_cast<std::uint64_t>(number) << 3, &out);
  WriteVarint(value, &out);
  return out;
}

std::string LengthDelimited(std::uint32_t number, const std::string& payload) {
  std::string out;
  WriteVarint((static_cast<std::uint64_t>(number) << 3) | 2, &out);
  WriteVarint(payload.size(), &out);
  return out + payload;
}

struct Node {
  std::vector<std::string> inputs, outputs;
  std::string op_type, name;
  std::vector<Field> fields;
};

std::optional<Node> ReadNode(const std::string& payload) {
  std::optional<std::vector<Field>> fields = ReadFields(payload);
  if (!fields) return std::nullopt;
  Node node;
  for (const Field& field : *fields) {
    if (field.number == 1) node.inputs.push_back(field.payload);
    if (field.number == 2) node.outputs.push_back(field.payload);
    if (field.number == 3) node.name = field.payload;
    if (field.number == 4) node.op_type = field.payload;
  }
  node.fields = std::move(*fields);
  return node;
}

// The Mul node `mul` as a Swish of `input`: its other fields (outputs, name, domain) kept.
std::string SwishNode(const Node& mul, const std::string& input) {
  std::string payload = LengthDelimited(1, input);
  for (const Field& field : mul.fields) {
    if (field.number != 1 && field.number != 4) payload += field.raw;
  }
  return payload + LengthDelimited(4, "Swish");
}

// The graph's nodes rewritten, or nothing when it holds no pair to fuse or cannot be parsed.
std::optional<std::string> FuseInGraph(const std::string& graph, int* fused) {
  const std::optional<std::vector<Field>> fields = ReadFields(graph);
  if (!fields) return std::nullopt;
  std::vector<std::optional<Node>> nodes(fields->size());
  std::map<std::string, size_t> sigmoid_of_output;  // its output name -> field index
  std::map<std::string, int> consumers;             // tensor name -> nodes reading it
  for (size_t k = 0; k < fields->size(); ++k) {
    if ((*fields)[k].number != 1) continue;
    nodes[k] = ReadNode((*fields)[k].payload);
    if (!nodes[k]) return std::nullopt;
    for (const std::string& input : nodes[k]->inputs) ++consumers[input];
    if (nodes[k]->op_type == "Sigmoid" && nodes[k]->inputs.size() == 1 &&
        nodes[k]->outputs.size() == 1) {
      sigmoid_of_output[nodes[k]->outputs[0]] = k;
    }
  }
  std::set<size_t> dropped;
  std::map<size_t, std::string> swish_input;  // Mul field index -> x
  for (size_t k = 0; k < nodes.size(); ++k) {
    if (!nodes[k] || nodes[k]->op_type != "Mul" || nodes[k]->inputs.size() != 2) continue;
    for (int side = 0; side < 2; ++side) {
      const std::string& x = nodes[k]->inputs[static_cast<size_t>(side)];
      const std::string& s = nodes[k]->inputs[static_cast<size_t>(1 - side)];
      const auto sigmoid = sigmoid_of_output.find(s);
      if (sigmoid == sigmoid_of_output.end() || consumers[s] != 1 ||
          nodes[sigmoid->second]->inputs[0] != x || dropped.count(sigmoid->second) > 0) {
        continue;
      }
      dropped.insert(sigmoid->second);
      swish_input[k] = x;
      break;
    }
  }
  if (swish_input.empty()) return std::nullopt;
  std::string out;
  for (size_t k = 0; k < fields->size(); ++k) {
    if (dropped.count(k) > 0) continue;
    const auto swish = swish_input.find(k);
    out += swish == swish_input.end() ? (*fields)[k].raw
                                      : LengthDelimited(1, SwishNode(*nodes[k], swish->second));
  }
  *fused = static_cast<int>(swish_input.size());
  return out;
}

// `model` with its graph replaced by `rewrite`'s result (nothing: the model unchanged).
template <typename Rewrite>
std::string RewriteGraph(const std::string& model, Rewrite rewrite) {
  const std::optional<std::vector<Field>> fields = ReadFields(model);
  if (!fields) return model;
  std::string out;
  bool rewritten = false;
  for (const Field& field : *fields) {
    std::optional<std::string> graph;
    if (field.number == 7 && !rewritten) graph = rewrite(field.payload);
    rewritten = rewritten || graph.has_value();
    out += graph ? LengthDelimited(7, *graph) : field.raw;
  }
  return rewritten ? out : model;
}

// A float tensor input named `name` of shape `dims` (ValueInfoProto).
std::string TensorInput(const std::string& name, const std::vector<int>& dims) {
  std::string shape;
  for (const int dim : dims)
    shape += LengthDelimited(1, Varint(1, static_cast<std::uint64_t>(dim)));
  const std::string tensor = Varint(1, 1) + LengthDelimited(2, shape);  // elem_type FLOAT
  return LengthDelimited(1, name) + LengthDelimited(2, LengthDelimited(1, tensor));
}

// The graph without its slicing stem (CutSliceStem), or nothing.
std::optional<std::string> CutStemInGraph(const std::string& graph, int height, int width,
                                          SliceStem* found) {
  const std::optional<std::vector<Field>> fields = ReadFields(graph);
  if (!fields) return std::nullopt;
  std::vector<std::optional<Node>> nodes(fields->size());
  std::map<std::string, size_t> producer;  // tensor -> node field index
  std::map<std::string, int> consumers;
  std::vector<size_t> inputs;  // input fields (graph inputs, initializers among them)
  for (size_t k = 0; k < fields->size(); ++k) {
    if ((*fields)[k].number == 11) inputs.push_back(k);
    if ((*fields)[k].number != 1) continue;
    nodes[k] = ReadNode((*fields)[k].payload);
    if (!nodes[k]) return std::nullopt;
    for (const std::string& output : nodes[k]->outputs) producer[output] = k;
    for (const std::string& input : nodes[k]->inputs) ++consumers[input];
  }
  // The first Concat whose inputs all come from Slices.
  for (size_t concat = 0; concat < nodes.size(); ++concat) {
    if (!nodes[concat] || nodes[concat]->op_type != "Concat" ||
        nodes[concat]->outputs.size() != 1) {
      continue;
    }
    // Walk back through Slices (data input first) to one graph input.
    std::set<size_t> stem;
    std::string image;
    bool sliced = true;
    std::vector<std::string> todo = nodes[concat]->inputs;
    while (!todo.empty() && sliced) {
      const std::string tensor = todo.back();
      todo.pop_back();
      const auto from = producer.find(tensor);
      if (from == producer.end()) {
        sliced = image.empty() || image == tensor;
        image = tensor;
        continue;
      }
      const Node& node = *nodes[from->second];
      sliced = node.op_type == "Slice" && !node.inputs.empty() && consumers[tensor] == 1;
      stem.insert(from->second);
      todo.push_back(node.inputs[0]);
    }
    if (!sliced || stem.size() < 2 || image.empty()) return std::nullopt;
    size_t image_input = fields->size();
    for (const size_t k : inputs) {
      const std::optional<std::vector<Field>> info = ReadFields((*fields)[k].payload);
      if (!info) return std::nullopt;
      for (const Field& part : *info) {
        if (part.number == 1 && part.payload == image) image_input = k;
      }
    }
    // Only the stem may read the image (each Slice's other inputs are constants).
    size_t image_readers = 0;
    for (const size_t k : stem) {
      image_readers += nodes[k]->inputs[0] == image ? 1 : 0;
    }
    if (image_input == fields->size() || consumers[image] != static_cast<int>(image_readers)) {
      return std::nullopt;
    }
    found->output = nodes[concat]->outputs[0];
    found->node = nodes[concat]->name;
    const int channels = 4 * 3;  // four phases of three colour channels
    std::string out;
    for (size_t k = 0; k < fields->size(); ++k) {
      if (k == concat || stem.count(k) > 0) continue;
      out += k == image_input
                 ? LengthDelimited(11,
                                   TensorInput(found->output, {1, channels, height / 2, width / 2}))
                 : (*fields)[k].raw;
    }
    return out;
  }
  return std::nullopt;
}

}  // namespace

std::string CutSliceStem(const std::string& model, int height, int width, SliceStem* stem) {
  *stem = SliceStem{};
  return RewriteGraph(
      model, [&](const std::string& graph) { return CutStemInGraph(graph, height, width, stem); });
}

std::string FuseSwish(const std::string& model, int* fused) {
  *fused = 0;
  return RewriteGraph(model,
                      [fused](const std::string& graph) { return FuseInGraph(graph, fused); });
}

}  // namespace stillmap
