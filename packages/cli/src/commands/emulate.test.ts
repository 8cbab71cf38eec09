import { join } from "node:path";
import { describe, expect, it } from "vitest";
import { parseCamera } from "./emulate.js";

const TABLE = join(import.meta.dirname, "..", "..", "..", "..", "examples", "scenes", "table.json");

describe("emulate --camera options", () => {
  it("none without --camera", () => expect(parseCamera({})).toBeUndefined());

  it("parses the pose, with the defaults", () => {
    expect(parseCamera({ camera: "1.5,0.2,1.3:0.4,0,0" })).toEqual({ position: [1.5, 0.2, 1.3], target: [0.4, 0, 0], width: 320, height: 240, noise: 0.001, dropout: 0.01 });
  });

  it("parses every option", () => {
    const c = parseCamera({ camera: "-1, 2, 0.5:0,0,0", "camera-size": "640X480", "camera-noise": "0.002", "camera-dropout": "0", scene: TABLE });
    expect(c).toEqual({ position: [-1, 2, 0.5], target: [0, 0, 0], width: 640, height: 480, noise: 0.002, dropout: 0, scene: TABLE });
  });

  it.each([
    [{ "camera-noise": "0.01" }, /--camera-noise goes with --camera/],
    [{ scene: TABLE }, /--scene goes with --camera/],
    [{ camera: "1,2,3" }, /--camera must be X,Y,Z:TX,TY,TZ/],
    [{ camera: "1,2,3:4,5" }, /--camera must be X,Y,Z:TX,TY,TZ/],
    [{ camera: "1,,3:4,5,6" }, /--camera must be X,Y,Z:TX,TY,TZ/],
    [{ camera: "1,2,3:4,5,6:7" }, /--camera must be X,Y,Z:TX,TY,TZ/],
    [{ camera: "1,2,3:4,5,1e5" }, /--camera: the target's coordinates must be between -10000 and 10000 m/],
    [{ camera: "1,2,3:1,2,3" }, /the point looked at must differ from the camera's position/],
    [{ camera: "1,2,3:1,2,0" }, /must not look straight up or down/],
    [{ camera: "1,2,3:0,0,0", "camera-size": "0x10" }, /--camera-size must be WxH, each 1 to 4096 pixels/],
    [{ camera: "1,2,3:0,0,0", "camera-size": "5000x10" }, /--camera-size must be WxH, each 1 to 4096 pixels/],
    [{ camera: "1,2,3:0,0,0", "camera-noise": "0.06" }, /--camera-noise must be between 0 and 0.05/],
    [{ camera: "1,2,3:0,0,0", "camera-dropout": "1.5" }, /--camera-dropout must be between 0 and 1/],
    [{ camera: "1,2,3:0,0,0", scene: "/nonexistent/scene.json" }, /--scene file not found: \/nonexistent\/scene\.json/],
  ])("refuses %j", (values, message) => expect(() => parseCamera(values)).toThrow(message));
});
