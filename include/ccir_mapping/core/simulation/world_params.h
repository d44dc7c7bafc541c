// Parameters of the simulated worlds. Every field is listed once in fields(), which gives its
// range, unit and help to validation, the simulator's command line and mission.yaml.
#pragma once

#include <string>
#include <vector>

namespace ccir_mapping::core::simulation {

struct WorldParams {
  /// mine | building | cave | cluttered.
  std::string world = "mine";

  // Room-and-pillar mine: a grid of pillars separated by drifts, closed by an outer wall.
  int mine_pillars_x = 5;
  int mine_pillars_y = 5;
  double mine_pillar_size_m = 10.0;
  double mine_drift_width_m = 5.0;
  double mine_height_m = 4.0;
  double mine_size_jitter_m = 0.5;
  double mine_rotation_jitter_deg = 3.0;
  double mine_rubble_per_pillar = 0.5;

  // Building: blocks of 2 x 2 rooms between corridors, one extruded storey.
  int building_blocks_x = 3;
  int building_blocks_y = 2;
  double building_room_size_m = 6.0;
  double building_corridor_width_m = 2.5;
  double building_door_width_m = 1.0;
  double building_height_m = 3.0;

  // Cave: irregular tunnels along the edges of a jittered grid graph, extruded.
  int cave_nodes_x = 4;
  int cave_nodes_y = 3;
  double cave_spacing_m = 20.0;
  double cave_radius_min_m = 1.5;
  double cave_radius_max_m = 3.0;
  double cave_roughness_m = 0.3;
  double cave_loop_probability = 0.3;
  double cave_height_m = 4.0;

  // Cluttered room: boxes at several heights and columns, lanes kept clear.
  double cluttered_size_x_m = 30.0;
  double cluttered_size_y_m = 20.0;
  double cluttered_height_m = 6.0;
  int cluttered_boxes = 80;
  int cluttered_columns = 10;

  /// Deepest a rubble box reaches into a drift from its pillar's face.
  static constexpr double kMineRubbleDepthMaxM = 0.8;

  /// Cell size of the ray-casting grid index.
  double index_cell_m = 2.0;

  static const std::vector<std::string>& worldChoices();
  /// Height of the chosen world's ceiling above its floor.
  double height() const;

  template <class Self, class Visitor>
  static void fields(Self& p, Visitor& v) {
    v.choice("world", p.world, worldChoices(), "environment to simulate");
    v.integer("mine_pillars_x", p.mine_pillars_x, "", 1, 60, "mine: pillars along x");
    v.integer("mine_pillars_y", p.mine_pillars_y, "", 1, 60, "mine: pillars along y");
    v.number("mine_pillar_size_m", p.mine_pillar_size_m, "m", 2.0, 50.0, "mine: pillar side");
    v.number("mine_drift_width_m", p.mine_drift_width_m, "m", 3.0, 20.0,
             "mine: width of the drifts between pillars");
    v.number("mine_height_m", p.mine_height_m, "m", 2.0, 10.0, "mine: floor to ceiling");
    v.number("mine_size_jitter_m", p.mine_size_jitter_m, "m", 0.0, 2.0,
             "mine: each pillar side varies within +-this");
    v.number("mine_rotation_jitter_deg", p.mine_rotation_jitter_deg, "deg", 0.0, 10.0,
             "mine: each pillar is rotated within +-this");
    v.number("mine_rubble_per_pillar", p.mine_rubble_per_pillar, "", 0.0, 1.0,
             "mine: mean number of rubble boxes beside each pillar");
    v.integer("building_blocks_x", p.building_blocks_x, "", 1, 30, "building: blocks along x");
    v.integer("building_blocks_y", p.building_blocks_y, "", 1, 30, "building: blocks along y");
    v.number("building_room_size_m", p.building_room_size_m, "m", 3.0, 30.0,
             "building: room side (a block holds 2 x 2 rooms)");
    v.number("building_corridor_width_m", p.building_corridor_width_m, "m", 1.5, 10.0,
             "building: corridor width");
    v.number("building_door_width_m", p.building_door_width_m, "m", 0.8, 3.0,
             "building: door width");
    v.number("building_height_m", p.building_height_m, "m", 2.0, 10.0,
             "building: floor to ceiling");
    v.integer("cave_nodes_x", p.cave_nodes_x, "", 2, 30, "cave: junctions along x");
    v.integer("cave_nodes_y", p.cave_nodes_y, "", 1, 30, "cave: junctions along y");
    v.number("cave_spacing_m", p.cave_spacing_m, "m", 8.0, 100.0, "cave: junction spacing");
    v.number("cave_radius_min_m", p.cave_radius_min_m, "m", 1.0, 10.0,
             "cave: narrowest tunnel half-width");
    v.number("cave_radius_max_m", p.cave_radius_max_m, "m", 1.0, 10.0,
             "cave: widest tunnel half-width");
    v.number("cave_roughness_m", p.cave_roughness_m, "m", 0.0, 1.0,
             "cave: amplitude of wall irregularity");
    v.number("cave_loop_probability", p.cave_loop_probability, "", 0.0, 1.0,
             "cave: chance that a tunnel closing a loop exists");
    v.number("cave_height_m", p.cave_height_m, "m", 2.0, 20.0, "cave: floor to ceiling");
    v.number("cluttered_size_x_m", p.cluttered_size_x_m, "m", 10.0, 200.0,
             "cluttered: room length");
    v.number("cluttered_size_y_m", p.cluttered_size_y_m, "m", 10.0, 200.0, "cluttered: room width");
    v.number("cluttered_height_m", p.cluttered_height_m, "m", 3.0, 30.0,
             "cluttered: floor to ceiling");
    v.integer("cluttered_boxes", p.cluttered_boxes, "", 0, 5000, "cluttered: boxes");
    v.integer("cluttered_columns", p.cluttered_columns, "", 0, 1000, "cluttered: columns");
    v.number("index_cell_m", p.index_cell_m, "m", 0.25, 50.0,
             "cell size of the ray-casting grid index");
  }

  /// Range errors of every field, then constraints().
  std::vector<std::string> validate() const;
  /// Errors of the constraints between fields.
  std::vector<std::string> constraints() const;
};

}  // namespace ccir_mapping::core::simulation
