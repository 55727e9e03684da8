// Groot2 round trip of the shipped trees: `visnav nodes --xml --tree T` declares every attribute
// the tree uses (Groot2 drops attributes that are not ports of the node's model when it saves),
// and the file as Groot2 saves it (TreeNodesModel + BehaviorTree, _uid/_fullpath metadata)
// validates with the same attributes.
#include <gtest/gtest.h>
#include <tinyxml2.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include "bt_test_support.hpp"

namespace {

namespace fs = std::filesystem;

int shell(const std::string& command) { return std::system((command + " >/dev/null 2>&1").c_str()); }

// ID -> declared port names, from a TreeNodesModel file.
std::map<std::string, std::set<std::string>> read_model(const fs::path& file) {
  std::map<std::string, std::set<std::string>> out;
  tinyxml2::XMLDocument doc;
  EXPECT_EQ(doc.LoadFile(file.string().c_str()), tinyxml2::XML_SUCCESS) << file;
  const auto* model = doc.RootElement() != nullptr ? doc.RootElement()->FirstChildElement("TreeNodesModel") : nullptr;
  if (model == nullptr) return out;
  for (const auto* n = model->FirstChildElement(); n != nullptr; n = n->NextSiblingElement()) {
    auto& ports = out[n->Attribute("ID")];
    for (const auto* p = n->FirstChildElement(); p != nullptr; p = p->NextSiblingElement())
      if (const char* name = p->Attribute("name")) ports.insert(name);
  }
  return out;
}

std::string node_id(const tinyxml2::XMLElement* el) {
  const std::string name = el->Name();
  if (name == "Action" || name == "Condition" || name == "Control" || name == "Decorator") return el->Attribute("ID");
  if (name == "SubTree") return el->Attribute("ID");
  return name;
}

// Rewrites `doc` as Groot2 saves it: attributes that are declared ports (or name, ID and
// '_'-attributes) are kept, Groot2's _uid/_fullpath are added, the model is appended. Returns
// the attributes dropped (must be none).
std::vector<std::string> groot_save(tinyxml2::XMLDocument& doc, const std::map<std::string, std::set<std::string>>& model,
                                    const fs::path& palette) {
  std::vector<std::string> dropped;
  int uid = 1;
  for (auto* bt = doc.RootElement()->FirstChildElement("BehaviorTree"); bt != nullptr;
       bt = bt->NextSiblingElement("BehaviorTree")) {
    std::vector<tinyxml2::XMLElement*> stack;
    for (auto* c = bt->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) stack.push_back(c);
    while (!stack.empty()) {
      auto* el = stack.back();
      stack.pop_back();
      const std::string id = node_id(el);
      const auto it = model.find(id);
      std::vector<std::string> remove;
      for (const auto* a = el->FirstAttribute(); a != nullptr; a = a->Next()) {
        const std::string n = a->Name();
        if (n == "name" || n == "ID" || n.front() == '_') continue;
        if (it == model.end() || it->second.count(n) == 0) remove.push_back(n);
      }
      for (const auto& n : remove) {
        dropped.push_back(id + "." + n);
        el->DeleteAttribute(n.c_str());
      }
      el->SetAttribute("_uid", uid++);
      for (auto* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) stack.push_back(c);
    }
  }
  tinyxml2::XMLDocument pal;
  EXPECT_EQ(pal.LoadFile(palette.string().c_str()), tinyxml2::XML_SUCCESS);
  doc.RootElement()->InsertEndChild(pal.RootElement()->FirstChildElement("TreeNodesModel")->DeepClone(&doc));
  return dropped;
}

TEST(Groot2, EveryShippedTreeSurvivesASaveWithAllAttributes) {
  const fs::path src = VISNAV_TEST_SOURCE_DIR;
  const std::string cli = VISNAV_TEST_CLI;
  const fs::path config = src / "config/sim_campus.yaml";  // loads every shipped nodes plugin (teleop too)
  bt_test::TempDir tmp;
  fs::copy(src / "trees", tmp.path() / "trees", fs::copy_options::recursive);  // saved copies go there
  int checked = 0;
  for (const auto& entry : fs::directory_iterator(tmp.path() / "trees")) {
    if (entry.path().extension() != ".xml") continue;
    SCOPED_TRACE(entry.path().filename().string());
    const fs::path palette = tmp.path() / "palette.xml";
    ASSERT_EQ(shell("'" + cli + "' nodes --xml --config '" + config.string() + "' --tree '" + entry.path().string() +
                    "' --output '" + palette.string() + "'"),
              0);
    const auto model = read_model(palette);
    ASSERT_GT(model.size(), 20u);
    // The saved copy sits next to the copied original so that its includes resolve the same way.
    for (const fs::path& file : {entry.path()}) {
      tinyxml2::XMLDocument doc;
      ASSERT_EQ(doc.LoadFile(file.string().c_str()), tinyxml2::XML_SUCCESS);
      const auto dropped = groot_save(doc, model, palette);
      EXPECT_TRUE(dropped.empty()) << "Groot2 would drop: " << ::testing::PrintToString(dropped);
      const fs::path saved = file.parent_path() / (".groot_saved_" + file.filename().string());
      ASSERT_EQ(doc.SaveFile(saved.string().c_str()), tinyxml2::XML_SUCCESS);
      const int rc = shell("'" + cli + "' validate --config '" + config.string() + "' --tree '" + saved.string() + "'");
      fs::remove(saved);
      EXPECT_EQ(rc, 0) << "the Groot2-saved copy of " << file << " does not validate";
    }
    ++checked;
  }
  EXPECT_GE(checked, 5);
}

TEST(Groot2, SubTreeModelsDeclareTheRemappedPortsOfIncludedTrees) {
  bt_test::TempDir dir;
  dir.write("lib/sub.xml", R"(<root BTCPP_format="4"><BehaviorTree ID="S"><AlwaysSuccess/></BehaviorTree></root>)");
  const auto main = dir.write("main.xml", R"(<root BTCPP_format="4" main_tree_to_execute="M">
  <include path="lib/sub.xml"/>
  <BehaviorTree ID="M"><Sequence><SubTree ID="S" b="1" a="{x}" _autoremap="false" name="n"/><SubTree ID="S" c="{y}"/></Sequence></BehaviorTree>
</root>)");
  auto models = visnav::bt::subtree_models(main);
  ASSERT_TRUE(models.ok()) << models.error().message;
  ASSERT_EQ(models->size(), 2u);
  EXPECT_EQ((*models)[0].id, "M");
  EXPECT_TRUE((*models)[0].ports.empty());
  EXPECT_EQ((*models)[1].id, "S");  // defined in the included file
  EXPECT_EQ((*models)[1].ports, (std::vector<std::string>{"a", "b", "c"}));
  visnav::bt::NodeRegistry registry;
  ASSERT_TRUE(visnav::bt::register_builtin_nodes(registry).ok());
  const std::string xml = visnav::bt::write_nodes_model(registry, false, *models);
  EXPECT_NE(xml.find("<SubTree ID=\"S\">\n            <inout_port name=\"a\"/>"), std::string::npos) << xml;
}

}  // namespace
