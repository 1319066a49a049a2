// The SiLU rewrite of ONNX graphs (onnx_graph.h) on graphs written by hand in protobuf's wire
// format, read back by a reader of the test's own; damaged bytes come back unchanged.
#include "onnx_graph.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace stillmap {
namespace {

std::string Varint(std::uint64_t value) {
  std::string out;
  while (value >= 0x80) {
    out.push_back(static_cast<char>((value & 0x7F) | 0x80));
    value >>= 7;
  }
  out.push_back(static_cast<char>(value));
  return out;
}

std::string Bytes(int field, const std::string& payload) {
  return Varint(static_cast<std::uint64_t>(field) << 3 | 2) + Varint(payload.size()) + payload;
}

std::string NodeBytes(const std::string& op, const std::vector<std::string>& inputs,
                      const std::string& output, const std::string& name) {
  std::string node;
  for (const std::string& input : inputs) node += Bytes(1, input);
  node += Bytes(2, output) + Bytes(3, name) + Bytes(4, op);
  return node;
}

struct ReadNode {
  std::string op, name, output;
  std::vector<std::string> inputs;
};

// The test's own reader: length-delimited fields only (all that these graphs hold).
std::vector<std::pair<int, std::string>> Fields(const std::string& bytes) {
  std::vector<std::pair<int, std::string>> fields;
  size_t at = 0;
  auto varint = [&] {
    std::uint64_t value = 0;
    for (int shift = 0;; shift += 7) {
      const auto byte = static_cast<std::uint8_t>(bytes.at(at++));
      value |= static_cast<std::uint64_t>(byte & 0x7F) << shift;
      if (byte < 0x80) return value;
    }
  };
  while (at < bytes.size()) {
    const std::uint64_t key = varint();
    if ((key & 7) == 0) {
      fields.emplace_back(static_cast<int>(key >> 3), std::to_string(varint()));
      continue;
    }
    const std::uint64_t length = varint();
    fields.emplace_back(static_cast<int>(key >> 3), bytes.substr(at, length));
    at += length;
  }
  return fields;
}

std::vector<ReadNode> GraphNodes(const std::string& model, std::string* graph_name) {
  std::vector<ReadNode> nodes;
  for (const auto& [field, graph] : Fields(model)) {
    if (field != 7) continue;
    for (const auto& [number, payload] : Fields(graph)) {
      if (number == 2) *graph_name = payload;
      if (number != 1) continue;
      ReadNode node;
      for (const auto& [part, value] : Fields(payload)) {
        if (part == 1) node.inputs.push_back(value);
        if (part == 2) node.output = value;
        if (part == 3) node.name = value;
        if (part == 4) node.op = value;
      }
      nodes.push_back(node);
    }
  }
  return nodes;
}

std::string HandMadeModel() {
  std::string graph;
  graph += Bytes(1, NodeBytes("Sigmoid", {"x"}, "s", "sig1"));
  graph += Bytes(1, NodeBytes("Mul", {"x", "s"}, "y", "mul1"));  // SiLU: fused
  graph += Bytes(1, NodeBytes("Sigmoid", {"a"}, "b", "sig2"));
  graph += Bytes(1, NodeBytes("Mul", {"b", "c"}, "d", "mul2"));  // by another tensor: kept
  graph += Bytes(1, NodeBytes("Sigmoid", {"e"}, "f", "sig3"));
  graph += Bytes(1, NodeBytes("Mul", {"f", "e"}, "g", "mul3"));  // SiLU, but f is read twice
  graph += Bytes(1, NodeBytes("Add", {"f", "g"}, "h", "add"));
  graph += Bytes(2, "hand made");
  return Varint(1 << 3 | 0) + Varint(8) + Bytes(7, graph) + Bytes(2, "producer");
}

TEST(OnnxSwishTest, FusesOnlySigmoidTimesItsOwnInput) {
  int fused = -1;
  const std::string out = FuseSwish(HandMadeModel(), &fused);
  EXPECT_EQ(fused, 1);
  std::string graph_name;
  const std::vector<ReadNode> nodes = GraphNodes(out, &graph_name);
  EXPECT_EQ(graph_name, "hand made");
  ASSERT_EQ(nodes.size(), 6u);
  EXPECT_EQ(nodes[0].op, "Swish");
  EXPECT_EQ(nodes[0].inputs, std::vector<std::string>{"x"});
  EXPECT_EQ(nodes[0].output, "y");
  EXPECT_EQ(nodes[0].name, "mul1");
  const std::vector<std::string> rest = {"Sigmoid", "Mul", "Sigmoid", "Mul", "Add"};
  for (size_t k = 0; k < rest.size(); ++k) EXPECT_EQ(nodes[k + 1].op, rest[k]) << k;
  EXPECT_EQ(nodes[2].inputs, (std::vector<std::string>{"b", "c"}));
  // The fields around the graph are kept as they were.
  const auto fields = Fields(out);
  ASSERT_EQ(fields.size(), 3u);
  EXPECT_EQ(fields[0], std::make_pair(1, std::string("8")));
  EXPECT_EQ(fields[2], std::make_pair(2, std::string("producer")));
}

TEST(OnnxSwishTest, DamagedOrForeignBytesComeBackUnchanged) {
  const std::string model = HandMadeModel();
  // A cut inside a field leaves a length that runs past the bytes: unchanged. A cut just after
  // the graph leaves a well-formed message without the trailing field (protobuf cannot tell),
  // and the graph is rewritten.
  const size_t graph_end = model.size() - Bytes(2, "producer").size();
  int fused = -1;
  for (size_t cut = 0; cut < model.size(); ++cut) {
    const std::string truncated = model.substr(0, cut);
    const std::string out = FuseSwish(truncated, &fused);
    if (cut == graph_end) {
      EXPECT_EQ(fused, 1);
    } else {
      EXPECT_EQ(out, truncated) << "cut at " << cut;
      EXPECT_EQ(fused, 0) << "cut at " << cut;
    }
  }
  const std::string foreign = "not a protobuf \xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff";
  EXPECT_EQ(FuseSwish(foreign, &fused), foreign);
  EXPECT_EQ(fused, 0);
}

}  // namespace
}  // namespace stillmap
