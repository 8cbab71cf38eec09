import { chmodSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { createServer } from "node:net";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, afterEach, beforeAll, describe, expect, it } from "vitest";
import { parseGenerateArgs } from "./commands/generate-options.js";
import { bundledRobotsDir } from "./examples.js";
import { preflight, urdfLinks } from "./preflight.js";

let work: string;
const savedPython = process.env["ROBWOT_PYTHON"];
const ARM = `<?xml version="1.0"?>
<robot name="arm">
  <!-- <link name="commented_out"/> -->
  <link name="base"/>
  <link name='upper'><visual><geometry><box size="1 1 1"/></geometry></visual></link>
  <link
    name="tip"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="upper"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>
`;

/** A stand-in for the backend's Python that answers the facts probe as told (and could start no backend). */
function fakePython(facts: { pybulletData: string | null; ray: boolean }): string {
  const file = join(work, `python-${Math.random().toString(36).slice(2)}`);
  writeFileSync(file, `#!/bin/sh\necho '${JSON.stringify(facts)}'\n`);
  chmodSync(file, 0o755);
  return file;
}

/** A port nothing listens at. */
async function closedPort(): Promise<number> {
  const server = createServer();
  await new Promise<void>((r) => server.listen(0, "127.0.0.1", r));
  const { port } = server.address() as { port: number };
  await new Promise((r) => server.close(r));
  return port;
}

const generate = (...args: string[]) => parseGenerateArgs([join(work, "arm.urdf"), "--out", join(work, "twin"), ...args]);

beforeAll(() => {
  work = mkdtempSync(join(tmpdir(), "robwot-preflight-"));
  writeFileSync(join(work, "arm.urdf"), ARM);
});
afterAll(() => rmSync(work, { recursive: true, force: true }));
afterEach(() => {
  if (savedPython === undefined) delete process.env["ROBWOT_PYTHON"];
  else process.env["ROBWOT_PYTHON"] = savedPython;
});

describe("urdfLinks", () => {
  it.each([
    ["every <link name>, sorted, comments ignored, either quote", ARM, ["base", "tip", "upper"]],
    ["none", '<robot name="r"/>', []],
    ["a DOCTYPE (entities may name links): left to the backend", `<!DOCTYPE robot [<!ENTITY n "x">]>${ARM}`, null],
    ["an unexpanded xacro name: left to the backend", '<robot name="r"><link name="${prefix}base"/></robot>', null],
  ])("%s", (_name, text, links) => {
    expect(urdfLinks(text)).toEqual(links);
  });

  it("reads the bundled UR3's links", () => {
    expect(urdfLinks(readFileSync(join(bundledRobotsDir(), "ur3.urdf"), "utf8"))).toEqual(expect.arrayContaining(["base_link", "ee_link"]));
  });
});

describe("options refused before any backend starts", () => {
  it("--ee naming no link of the URDF: the links listed, the backend's code", async () => {
    process.env["ROBWOT_PYTHON"] = join(work, "no-python-here"); // a backend could not even start
    await expect(preflight(generate("--ee", "hand"))).rejects.toMatchObject({
      code: "E_UNKNOWN_LINK",
      message: expect.stringMatching(/--ee: unknown link 'hand' in .*arm\.urdf; available: base, tip, upper$/) as unknown,
    });
  });

  it("--ee of an example robot in pybullet_data: its URDF found through the backend's Python", async () => {
    writeFileSync(join(work, "TwoJointRobot_wo_fixedJoints.urdf"), ARM);
    // no such file there: the backend names what it cannot read
    process.env["ROBWOT_PYTHON"] = fakePython({ pybulletData: join(work, "elsewhere"), ray: false });
    await expect(preflight(parseGenerateArgs(["two_joint", "--ee", "hand"]))).resolves.toBeUndefined();
    process.env["ROBWOT_PYTHON"] = fakePython({ pybulletData: work, ray: false });
    await expect(preflight(parseGenerateArgs(["two_joint", "--ee", "hand"]))).rejects.toThrow(/unknown link 'hand'.*available: base, tip, upper/);
  });

  it("--cluster without Ray in the backend's Python names the extra", async () => {
    process.env["ROBWOT_PYTHON"] = fakePython({ pybulletData: null, ray: false });
    await expect(preflight(generate("--cluster", "auto"))).rejects.toMatchObject({ code: "E_CLUSTER", message: expect.stringMatching(/cluster extra/) as unknown });
  });

  it("--cluster at an address where nothing listens", async () => {
    process.env["ROBWOT_PYTHON"] = fakePython({ pybulletData: null, ray: true });
    const port = await closedPort();
    await expect(preflight(generate("--cluster", `ray://127.0.0.1:${port}`))).rejects.toThrow(`cannot connect to the Ray cluster at 'ray://127.0.0.1:${port}'`);
  });

  it("--cluster that is no address, whichever backend runs it", async () => {
    await expect(preflight(generate("--cluster", "my-cluster", "--backend", "ws://127.0.0.1:1"))).rejects.toThrow(/--cluster must be auto, ray:\/\/HOST:PORT or HOST:PORT, got "my-cluster"/);
  });

  it("passes what it cannot know: a remote backend's Ray and network, an existing link", async () => {
    process.env["ROBWOT_PYTHON"] = join(work, "no-python-here");
    await expect(preflight(generate("--cluster", "127.0.0.1:1", "--backend", "ws://127.0.0.1:1"))).resolves.toBeUndefined();
    await expect(preflight(generate("--ee", "tip"))).resolves.toBeUndefined();
  });
});
