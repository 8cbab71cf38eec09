/**
 * `robwot generate` with robots as ROS users have them, placed where they stand: `--base` (twin.json,
 * the served pose), xacro files with `--xacro-arg`, unexpanded xacro refused with file:line, and
 * `package://` resolved from ROS_PACKAGE_PATH or refused with the option that fixes it. Real CLI, backend
 * and servient.
 */
import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient } from "../packages/servient/src/index.js";
import { REPO, runCli, TINY_URDF } from "./cli-run.js";
import { http } from "./serve-helpers.js";

const MODELS = join(REPO, "sim-backend", "tests", "models");
const XACRO = join(MODELS, "ros_ws", "tinyxacro_description", "urdf", "arm.urdf.xacro");
const SAMPLES = "2000";
let work: string;

beforeAll(() => {
  work = mkdtempSync(join(tmpdir(), "robwot-ros-"));
  writeFileSync(join(work, "tiny.urdf"), TINY_URDF);
});
afterAll(() => rmSync(work, { recursive: true, force: true }));

const json = (file: string): Record<string, any> => JSON.parse(readFileSync(file, "utf8")) as Record<string, any>;

describe("--base X,Y,Z[,ROLL,PITCH,YAW]", () => {
  it("places the robot: twin.json holds the pose, serve reports the end effector shifted and turned by it", async () => {
    const out = join(work, "based");
    // roll = pi/2 turns the arm's +Z (tip 0.65 m above the base at zero joints) into -Y
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--base", `1, 2,0.5,${Math.PI / 2},0,0`, "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    const robot = json(join(out, "twin.json")).robot;
    expect(robot.basePosition).toEqual([1, 2, 0.5]);
    const s = Math.SQRT1_2;
    robot.baseOrientation.forEach((v: number, i: number) => expect(v).toBeCloseTo([s, 0, 0, s][i]!, 9));
    // the workspace is sampled in the world frame: every point lies on the base's side
    const bounds = json(join(out, "workspace.json")).bounds;
    expect(bounds.max[1]).toBeLessThan(2 + 0.2);
    expect(bounds.min[1]).toBeLessThan(2 - 0.5);
    const served = await startServient({ twins: [out], port: 0, realtime: 0 });
    try {
      const pose = (await http(`${served.things[0]!.tdUrl}/properties/getCartesianPosition`)).body;
      expect(pose.x).toBeCloseTo(1, 6);
      expect(pose.y).toBeCloseTo(2 - 0.65, 6);
      expect(pose.z).toBeCloseTo(0.5, 6);
    } finally {
      await served.stop();
    }
  }, 180_000);

  it.each([
    ["1,2", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["1,2,3,4", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["1,,3", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["a,b,c", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["0,0,1e9", "within ±10000 m"],
    ["0,0,0,0,0,1e5", "within ±10000 rad"],
  ])("refuses --base %s with a usage error naming the option", async (value, says) => {
    const out = join(work, "never-base");
    const r = await runCli(["generate", join(work, "tiny.urdf"), `--base=${value}`, "--out", out]);
    expect(r.code).toBe(2);
    expect(r.stderr).toContain("--base");
    expect(r.stderr).toContain(says);
    expect(existsSync(out)).toBe(false);
  });

  it("refuses --base when the scene places the same robot too", async () => {
    const scene = join(work, "placing.scene.json");
    writeFileSync(scene, JSON.stringify({ version: 1, obstacles: [], robots: [{ urdf: join(work, "tiny.urdf"), basePosition: [0.3, 0, 0] }] }));
    const out = join(work, "never-both");
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--scene", scene, "--base", "1,0,0", "--samples", SAMPLES, "--out", out]);
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(/--base places the robot, but the scene .*placing\.scene\.json places it too/);
    expect(existsSync(out)).toBe(false);
  }, 60_000);
});

describe("xacro", () => {
  it("expands robot.urdf.xacro with --xacro-arg: robot.urdf is the expansion, twin.json records the args, serve uses it", async () => {
    const out = join(work, "xacro");
    const r = await runCli(["generate", XACRO, "--xacro-arg", "upper_length:=0.25", "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    expect(r.stdout).toContain("twin \"tinyxacro\" written");
    expect(json(join(out, "twin.json")).robot.xacro).toEqual({ file: "arm.urdf.xacro", args: { upper_length: "0.25" } });
    const urdf = readFileSync(join(out, "robot.urdf"), "utf8");
    expect(urdf).not.toMatch(/\$[{(]|xmlns:xacro|<xacro:/);
    expect(urdf).toMatch(/<box size="0.04 0.04 0.25"/);
    expect([...urdf.matchAll(/<mesh filename="([^"]+)"/g)].map((m) => m[1])).toEqual(["meshes/link.stl", "meshes/link.stl"]);
    expect(existsSync(join(out, "meshes", "link.stl"))).toBe(true);
    const served = await startServient({ twins: [out], port: 0, realtime: 0 });
    try {
      const pose = (await http(`${served.things[0]!.tdUrl}/properties/getCartesianPosition`)).body;
      expect(pose.z).toBeCloseTo(0.1 + 0.05 + 0.25 + 0.2, 6); // the arg's upper arm, not the default 0.3
    } finally {
      await served.stop();
    }
  }, 180_000);

  it("finds package:// on ROS_PACKAGE_PATH; without it names the package and the option that fixes it", async () => {
    const out = join(work, "xacro-tool");
    const args = ["generate", XACRO, "--xacro-arg", "with_tool:=true", "--samples", SAMPLES, "--out", out];
    const saved = process.env.ROS_PACKAGE_PATH;
    try {
      delete process.env.ROS_PACKAGE_PATH;
      const missing = await runCli(args);
      expect(missing.code).toBe(1);
      expect(missing.stderr).toContain(`${XACRO}: package://tinytool/meshes/tool.stl: ROS package 'tinytool' not found`);
      expect(missing.stderr).toContain("give --package-root tinytool=DIR");
      expect(missing.stderr).toContain("ROS_PACKAGE_PATH");
      expect(existsSync(out)).toBe(false);
      process.env.ROS_PACKAGE_PATH = join(MODELS, "ros_ws", "extra");
      const r = await runCli(args);
      expect(r.code, r.stderr).toBe(0);
      expect(readFileSync(join(out, "robot.urdf"), "utf8")).toContain('<link name="tool">');
    } finally {
      if (saved === undefined) delete process.env.ROS_PACKAGE_PATH;
      else process.env.ROS_PACKAGE_PATH = saved;
    }
  }, 180_000);

  it("refuses xacro's errors naming the file and line", async () => {
    const bad = join(work, "bad.urdf.xacro");
    writeFileSync(bad, '<robot name="bad" xmlns:xacro="http://www.ros.org/wiki/xacro">\n<link name="base"/>\n<link name="$(arg prefix)arm"/>\n</robot>\n');
    const r = await runCli(["generate", bad, "--out", join(work, "never-xacro")]);
    expect(r.code).toBe(1);
    expect(r.stderr).toContain(`robwot: error: ${bad}:3: xacro: undefined argument 'prefix': give it with --xacro-arg prefix:=VALUE`);
  }, 60_000);

  it("an error in the expanded URDF names its line there and keeps the file for the user to read", async () => {
    const xacro = join(work, "nolimit.urdf.xacro");
    writeFileSync(xacro, '<robot name="nl" xmlns:xacro="http://www.ros.org/wiki/xacro">\n<xacro:property name="axis" value="0 0 1"/>\n<link name="a"/><link name="b"/>\n<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="${axis}"/></joint>\n</robot>\n');
    const r = await runCli(["generate", xacro, "--out", join(work, "never-nolimit")]);
    expect(r.code).toBe(1);
    const m = /robwot: error: (\S+\/nolimit\.urdf):5: revolute joint 'j' needs <limit lower=\.\.\. upper=\.\.\.> \(the URDF expanded from (\S+), kept there\)/.exec(r.stderr);
    expect(m, r.stderr).not.toBeNull();
    expect(m![2]).toBe(xacro);
    expect(readFileSync(m![1]!, "utf8")).toContain('<axis xyz="0 0 1"');
    rmSync(join(m![1]!, ".."), { recursive: true, force: true });
  }, 60_000);

  it.each([
    [["--xacro-arg", "upper_length=0.25"], 'NAME:=VALUE (e.g. prefix:=left_), got "upper_length=0.25"'],
    [["--xacro-arg", "a:=1", "--xacro-arg", "a:=2"], "--xacro-arg a given twice"],
  ])("refuses malformed --xacro-arg %j", async (extra, says) => {
    const r = await runCli(["generate", XACRO, ...extra, "--out", join(work, "never-arg")]);
    expect(r.code).toBe(2);
    expect(r.stderr).toContain(says);
  });

  it("refuses --xacro-arg for a plain URDF", async () => {
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--xacro-arg", "a:=1", "--out", join(work, "never-arg")]);
    expect(r.code).toBe(2);
    expect(r.stderr).toContain("--xacro-arg is for a xacro file (robot.urdf.xacro)");
  });
});

describe("xacro left in a URDF", () => {
  it.each([
    ["xacro_as_urdf.urdf", 10, "unexpanded xacro '0 0 ${L}' in attribute 'xyz' of <origin>"],
    ["xacro_in_collision.urdf", 7, "unexpanded xacro '0.1 0.1 $(arg arm_length)' in attribute 'size' of <box>"],
  ])("%s is refused with file:line and the hint", async (name, line, says) => {
    const out = join(work, "never-unexpanded");
    const r = await runCli(["generate", join(MODELS, name), "--samples", SAMPLES, "--out", out]);
    expect(r.code).toBe(1);
    expect(r.stderr).toContain(`robwot: error: ${join(MODELS, name)}:${line}: ${says}: a xacro file? name it .xacro or pass it as robot.urdf.xacro`);
    expect(r.stderr).not.toContain("expected 3 numbers");
    expect(existsSync(out)).toBe(false);
  }, 60_000);
});

describe("--moveit-config DIR, the SRDF and --group", () => {
  const CONFIG = join(MODELS, "ros_ws", "tinyxacro_moveit_config");

  it("generates from a MoveIt config: its xacro and args, its SRDF, its joint_limits.yaml, its first end effector", async () => {
    const out = join(work, "moveit");
    const r = await runCli(["generate", "--moveit-config", CONFIG, "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    const robot = json(join(out, "twin.json")).robot;
    expect(robot.xacro).toEqual({ file: "arm.urdf.xacro", args: { upper_length: "0.25" } }); // .setup_assistant's xacro_args
    expect(robot.srdf).toBe("robot.srdf");
    expect(readFileSync(join(out, "robot.srdf"), "utf8")).toBe(readFileSync(join(CONFIG, "config", "tinyxacro.srdf"), "utf8"));
    expect(robot.eeLink).toBe("fore"); // the SRDF's first <end_effector>, not the URDF's tip
    const urdf = readFileSync(join(out, "robot.urdf"), "utf8");
    const velocity = (joint: string) => new RegExp(`<joint name="${joint}"[\\s\\S]*?velocity="([^"]+)"`).exec(urdf)?.[1];
    expect([velocity("yaw"), velocity("shoulder"), velocity("elbow")]).toEqual(["0.5", "1", "0.75"]); // shoulder: has_velocity_limits false
    const served = await startServient({ twins: [out], port: 0, realtime: 0 });
    try {
      const pose = (await http(`${served.things[0]!.tdUrl}/properties/getCartesianPosition`)).body;
      // the elbow, where fore starts, with the SRDF's home state applied (shoulder 0.5 rad, the upper arm 0.25 m)
      expect(pose.z).toBeCloseTo(0.1 + 0.05 + 0.25 * Math.cos(0.5), 6);
    } finally {
      await served.stop();
    }
  }, 180_000);

  it("--group picks the group's end effector and is recorded; an unknown group lists the SRDF's", async () => {
    const out = join(work, "moveit-arm");
    const r = await runCli(["generate", "--moveit-config", CONFIG, "--group", "arm", "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    const robot = json(join(out, "twin.json")).robot;
    expect([robot.eeLink, robot.group]).toEqual(["tip", "arm"]);
    const bad = await runCli(["generate", "--moveit-config", CONFIG, "--group", "legs", "--out", join(work, "never-group")]);
    expect(bad.code).toBe(2);
    expect(bad.stderr).toContain("--group legs: no such planning group in the SRDF (groups: arm, to_elbow, hand)");
    expect(existsSync(join(work, "never-group"))).toBe(false);
  }, 180_000);

  it("the SRDF's home state is the pose serve starts in; twin.json records it and where it came from", async () => {
    const srdf = join(work, "home.srdf");
    writeFileSync(
      srdf,
      '<?xml version="1.0"?>\n<robot name="tiny">\n  <group name="arm">\n    <chain base_link="base" tip_link="tip"/>\n  </group>\n' +
        '  <group_state name="home" group="arm">\n    <joint name="shoulder" value="0.5"/>\n    <joint name="elbow" value="-0.25"/>\n  </group_state>\n' +
        '  <end_effector name="hand" parent_link="tip" group="arm" parent_group="arm"/>\n</robot>\n',
    );
    const out = join(work, "homed");
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--srdf", srdf, "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    expect(json(join(out, "twin.json")).robot.home).toEqual({ joints: { shoulder: 0.5, elbow: -0.25 }, from: 'SRDF group_state "home" of group "arm"' });
    const served = await startServient({ twins: [out], port: 0, realtime: 0 });
    try {
      const joints = (await http(`${served.things[0]!.tdUrl}/properties/getJointPosition`)).body;
      expect(joints).toEqual({ yaw: 0, shoulder: 0.5, elbow: -0.25 });
    } finally {
      await served.stop();
    }
    // --home wins over the SRDF's home: the joints it names, the others where the robot loads
    const over = join(work, "homed-cli");
    const h = await runCli(["generate", join(work, "tiny.urdf"), "--srdf", srdf, "--home", "elbow=0.3", "--samples", SAMPLES, "--out", over]);
    expect(h.code, h.stderr).toBe(0);
    expect(json(join(over, "twin.json")).robot.home).toEqual({ joints: { yaw: 0, shoulder: 0, elbow: 0.3 }, from: "--home" });
  }, 120_000);

  it("--limits FILE: a joint_limits.yaml's velocities replace the URDF's and its accelerations time the moves, recorded in twin.json; bad values are refused", async () => {
    const yaml = join(work, "joint_limits.yaml");
    writeFileSync(
      yaml,
      "joint_limits:\n  shoulder:\n    has_velocity_limits: true\n    max_velocity: 0.25\n    has_acceleration_limits: true\n    max_acceleration: 0.5\n  elbow:\n    has_velocity_limits: false\n    max_velocity: 9\n",
    );
    const out = join(work, "limited");
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--limits", yaml, "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    const urdf = readFileSync(join(out, "robot.urdf"), "utf8");
    const velocity = (joint: string) => new RegExp(`<joint name="${joint}"[\\s\\S]*?velocity="([^"]+)"`).exec(urdf)?.[1];
    expect([velocity("yaw"), velocity("shoulder"), velocity("elbow")]).toEqual(["1", "0.25", "1.5"]);
    const robot = json(join(out, "twin.json")).robot;
    expect(robot.limits).toEqual({ file: "joint_limits.yaml", velocities: { shoulder: 0.25 }, accelerations: { shoulder: 0.5 } });
    expect(robot.accelerations).toEqual({ shoulder: 0.5 });
    expect(robot.xacro).toBeUndefined(); // a plain URDF, not a xacro
    // served: 0.5 rad of the shoulder at 0.25 rad/s and 0.5 rad/s^2 is a trapezoid of 0.5 / 0.25 + 0.25 / 0.5 = 2.5 s
    const served = await startServient({ twins: [out], port: 0, realtime: 0 });
    try {
      const base = served.things[0]!.tdUrl;
      const plan = await http(`${base}/actions/validateProgram`, {
        method: "POST",
        headers: { "content-type": "application/json" },
        body: JSON.stringify({ steps: [{ joints: { yaw: 0, shoulder: 0.5, elbow: 0 } }] }),
      });
      expect(plan.status, JSON.stringify(plan.body)).toBe(200);
      expect(plan.body.cycleTime).toBeCloseTo(2.5, 1);
    } finally {
      await served.stop();
    }
    // max_jerk: recorded, loaded by serve, every motion jerk-limited: the shoulder's 0.5 rad (trapezoid 2.5 s, its
    // cruise 1.5 s longer than A / J = 0.25 s) takes 2.5 + 0.25 s, its jerk by third differences within 2 rad/s^3
    writeFileSync(yaml, "joint_limits:\n  shoulder:\n    has_velocity_limits: true\n    max_velocity: 0.25\n    has_acceleration_limits: true\n    max_acceleration: 0.5\n    has_jerk_limits: true\n    max_jerk: 2\n");
    const jerked = join(work, "jerk-limited");
    const j = await runCli(["generate", join(work, "tiny.urdf"), "--limits", yaml, "--samples", SAMPLES, "--out", jerked]);
    expect(j.code, j.stderr).toBe(0);
    expect(json(join(jerked, "twin.json")).robot.jerks).toEqual({ shoulder: 2 });
    const jerkServed = await startServient({ twins: [jerked], port: 0, realtime: 0 });
    try {
      const plan = await http(`${jerkServed.things[0]!.tdUrl}/actions/validateProgram`, {
        method: "POST",
        headers: { "content-type": "application/json" },
        body: JSON.stringify({ steps: [{ joints: { yaw: 0, shoulder: 0.5, elbow: 0 } }] }),
      });
      expect(plan.status, JSON.stringify(plan.body)).toBe(200);
      expect(plan.body.cycleTime).toBeCloseTo(2.75, 1);
      const h = 1 / plan.body.trajectory.rate;
      const shoulder = (plan.body.trajectory.positions as number[][]).map((q) => q[1]!);
      const jerk = shoulder.slice(3).map((q, k) => Math.abs(q - 3 * shoulder[k + 2]! + 3 * shoulder[k + 1]! - shoulder[k]!) / h ** 3);
      expect(Math.max(...jerk)).toBeLessThanOrEqual(2 * 1.05);
      expect(Math.max(...jerk)).toBeGreaterThan(1);
    } finally {
      await jerkServed.stop();
    }
    writeFileSync(yaml, "joint_limits:\n  wrist:\n    has_acceleration_limits: true\n    max_acceleration: 1\n");
    const noJoint = await runCli(["generate", join(work, "tiny.urdf"), "--limits", yaml, "--samples", SAMPLES, "--out", join(work, "never-limits")]);
    expect(noJoint.code).toBe(1);
    expect(noJoint.stderr).toContain("accelerationLimits: 'wrist' is not a movable joint");
    writeFileSync(yaml, "joint_limits:\n  wrist:\n    has_velocity_limits: true\n    max_velocity: 1\n");
    const unknown = await runCli(["generate", join(work, "tiny.urdf"), "--limits", yaml, "--samples", SAMPLES, "--out", join(work, "never-limits")]);
    expect(unknown.code).toBe(1);
    expect(unknown.stderr).toMatch(/wrist/);
    writeFileSync(yaml, "joint_limits:\n  shoulder:\n    has_velocity_limits: true\n    max_velocity: -2\n");
    const bad = await runCli(["generate", join(work, "tiny.urdf"), "--limits", yaml, "--samples", SAMPLES, "--out", join(work, "never-limits")]);
    expect(bad.code).toBe(1);
    expect(bad.stderr).toContain("joint 'shoulder': max_velocity -2 must be a positive number");
    expect(existsSync(join(work, "never-limits"))).toBe(false);
  }, 120_000);

  it("--limits FILE: position limits (ros2_control's has_position_limits) bound a continuous joint, which becomes revolute; min >= max is refused", async () => {
    writeFileSync(join(work, "tiny-continuous.urdf"), TINY_URDF.replace('<joint name="yaw" type="revolute">', '<joint name="yaw" type="continuous">'));
    const yaml = join(work, "position_limits.yaml");
    writeFileSync(yaml, "joint_limits:\n  yaw:\n    has_position_limits: true\n    min_position: -1.5\n    max_position: 1.25\n");
    const out = join(work, "positions");
    const r = await runCli(["generate", join(work, "tiny-continuous.urdf"), "--limits", yaml, "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    const urdf = readFileSync(join(out, "robot.urdf"), "utf8");
    const yaw = /<joint name="yaw" type="(\w+)"[\s\S]*?<limit [^>]*>/.exec(urdf);
    expect(yaw?.[1]).toBe("revolute");
    expect(yaw?.[0]).toMatch(/lower="-1.5"/);
    expect(yaw?.[0]).toMatch(/upper="1.25"/);
    const td = json(join(out, "td.json"));
    const schema = td.properties.getJointPosition.properties.yaw;
    expect([schema.minimum, schema.maximum]).toEqual([-1.5, 1.25]);
    expect(json(join(out, "twin.json")).robot.limits.positions).toEqual({ yaw: [-1.5, 1.25] });
    writeFileSync(yaml, "joint_limits:\n  yaw:\n    has_position_limits: true\n    min_position: 1\n    max_position: 1\n");
    const bad = await runCli(["generate", join(work, "tiny-continuous.urdf"), "--limits", yaml, "--samples", SAMPLES, "--out", join(work, "never-positions")]);
    expect(bad.code).toBe(1);
    expect(bad.stderr).toContain("joint 'yaw': min_position 1.0 must be below max_position 1.0");
    expect(existsSync(join(work, "never-positions"))).toBe(false);
  }, 120_000);

  it("refuses an SRDF written for another robot (most of its names unknown) with file:line", async () => {
    const srdf = join(work, "other.srdf");
    writeFileSync(srdf, '<?xml version="1.0"?>\n<robot name="other">\n  <group name="arm">\n    <chain base_link="panda_link0" tip_link="panda_link8"/>\n  </group>\n</robot>\n');
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--srdf", srdf, "--samples", SAMPLES, "--out", join(work, "never-srdf")]);
    expect(r.code).toBe(1);
    expect(r.stderr).toContain(
      `robwot: error: ${srdf}:4: link 'panda_link0' is not a link of the robot (links: base, fore, tip, turret, upper): 2 of the 2 links and joints the SRDF names are not the robot's: is this the SRDF of another robot?`,
    );
    expect(existsSync(join(work, "never-srdf"))).toBe(false);
  }, 60_000);

  it("an SRDF entry naming a link the robot lacks is skipped with one warning (file:line, name); the rest is used", async () => {
    // as example-robot-data's Unitree Z1: its chain starts at a link "base" the URDF calls otherwise
    const srdf = join(work, "slip.srdf");
    writeFileSync(
      srdf,
      '<?xml version="1.0"?>\n<robot name="tiny_arm">\n  <group name="arm">\n    <chain base_link="base_link" tip_link="tip"/>\n' +
        '    <joint name="yaw"/><joint name="shoulder"/><joint name="elbow"/>\n  </group>\n' +
        '  <group_state name="home" group="arm"><joint name="yaw" value="0.5"/></group_state>\n' +
        '  <end_effector name="hand" parent_link="fore" group="arm"/>\n</robot>\n',
    );
    const out = join(work, "slip");
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--srdf", srdf, "--samples", SAMPLES, "--out", out, "--json"]);
    expect(r.code, r.stderr).toBe(0);
    const printed = JSON.parse(r.stdout) as { warnings: string[]; robot: { eeLink: string } };
    // robot.readSrdf and robot.load both report it: said once
    expect(printed.warnings).toEqual([`${srdf}:4: link 'base_link' is not a link of the robot: the chain base_link -> tip of group 'arm' skipped, as MoveIt does`]);
    const manifest = JSON.parse(readFileSync(join(out, "twin.json"), "utf8")) as { robot: { eeLink: string; home: { joints: Record<string, number> } } };
    expect(manifest.robot.eeLink).toBe("fore");
    expect(manifest.robot.home.joints).toEqual({ yaw: 0.5 });
  }, 60_000);

  it.each([
    [["--moveit-config", CONFIG, "robot.urdf"], "--moveit-config names the robot already"],
    [["tiny.urdf", "--group", "arm"], "--group names a planning group of an SRDF: give --srdf FILE or --moveit-config DIR"],
    [["--moveit-config", join(CONFIG, "nope")], "--moveit-config: folder not found"],
  ])("usage errors: %j", async (args, says) => {
    const r = await runCli(["generate", ...args.map((a) => (a === "tiny.urdf" ? join(work, a) : a)), "--out", join(work, "never-usage")]);
    expect(r.code).toBe(2);
    expect(r.stderr).toContain(says);
  });
});
