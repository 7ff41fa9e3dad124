// The page at /play in a real browser: Debian's Chromium, headless, driven
// by playwright-core, against a real dev server on loopback. The page must
// join over WebTransport, receive at least 60 snapshots, draw the demo's
// objects, and freeze when `inertia-admin pause` is issued.
//
// Run by `npm run test:browser` (the server built first: `.ci/run` has
// built it; INERTIA_SERVER_BIN and INERTIA_ADMIN_BIN name other builds,
// CHROMIUM_BIN another browser).

import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import { join } from "node:path";
import { after, before, test } from "node:test";

import { close, open, progress as progressOf, ROOT, until as untilOn, type Progress, type Session } from "./harness.js";

const SERVER = process.env.INERTIA_SERVER_BIN ?? join(ROOT, "target/debug/inertia-server");
const ADMIN = process.env.INERTIA_ADMIN_BIN ?? join(ROOT, "target/debug/inertia-admin");

let session: Session;
let page: Session["page"];
let dataDir: string;

async function progress(): Promise<Progress> {
  return progressOf(page);
}

async function until(what: string, limitMs: number, done: (p: Progress) => boolean): Promise<Progress> {
  return untilOn(page, what, limitMs, done);
}

interface Pixels {
  /** A digest of every pixel. */
  digest: string;
  /** Pixels by colour class. */
  counts: { sky: number; ground: number; blue: number; brown: number; total: number };
}

/** The canvas's pixels (without the HUD over it): a digest, and counts of
 * the colour classes of the demo's sky, ground and bodies. */
async function canvasPixels(): Promise<Pixels> {
  return page.evaluate(() => {
    const canvas = document.getElementById("world") as HTMLCanvasElement;
    const copy = document.createElement("canvas");
    copy.width = canvas.width;
    copy.height = canvas.height;
    const ctx = copy.getContext("2d")!;
    ctx.drawImage(canvas, 0, 0);
    const px = ctx.getImageData(0, 0, copy.width, copy.height).data;
    const counts = { sky: 0, ground: 0, blue: 0, brown: 0, total: px.length / 4 };
    let h = 0x811c9dc5;
    for (let i = 0; i < px.length; i += 4) {
      const [r, g, b] = [px[i]!, px[i + 1]!, px[i + 2]!];
      for (const x of [r, g, b, px[i + 3]!]) {
        h = Math.imul(h ^ x, 0x01000193) >>> 0;
      }
      if (b > 180 && r > 150 && g > 170 && b > r) counts.sky++;
      else if (g > r + 15 && g > b + 15) counts.ground++;
      else if (b > r + 40 && b > g + 10) counts.blue++;
      else if (r > g + 20 && g > b + 10) counts.brown++;
    }
    return { digest: `${copy.width}x${copy.height}:${h.toString(16)}`, counts };
  });
}

function admin(...args: string[]): void {
  const run = spawnSync(ADMIN, ["--credentials", join(dataDir, "dev-credentials.json"), ...args], {
    encoding: "utf8",
    timeout: 30_000,
  });
  assert.equal(run.status, 0, `inertia-admin ${args.join(" ")}: ${run.stderr}`);
}

before(async () => {
  session = await open(SERVER);
  page = session.page;
  dataDir = session.dataDir;
});

after(async () => {
  await close(session);
});

test("the page joins over WebTransport and receives snapshots", async () => {
  const p = await until("60 snapshots", 30_000, (p) => p.snapshots >= 60);
  assert.equal(p.state, "joined");
  assert.equal(p.game, "sandbox");
  assert.equal(p.headline, null, "the sandbox has no headline");
  assert.ok(p.entities > 100, `${p.entities} entities described`);
});

test("the page hears the game's messages and its chat goes to the rules and back", async () => {
  // The sandbox tells everyone who joined, the page included.
  await until("the join told", 10_000, (p) => p.log.some((l) => l.endsWith("joined")));
  // Enter asks for a line and sends it as the sandbox's chat request; the
  // rules tell it to everyone.
  page.once("dialog", (d) => void d.accept("hello from the page"));
  await page.keyboard.press("Enter");
  const p = await until("the chat line back", 10_000, (p) => p.log.some((l) => l.endsWith(": hello from the page")));
  assert.ok(p.messages >= 2, `${p.messages} messages`);
});

test("the page holds the game's match state from the snapshots", async () => {
  // The sandbox's players, a property of the match: the page is one.
  const p = await until("the players", 10_000, (p) => (p.matchState.players ?? 0) >= 1);
  assert.ok(p.matchState.players! >= 1, JSON.stringify(p.matchState));
});

test("the demo's soft bodies and fluid arrive as point sets", async () => {
  // Two XPBD ropes, the banner, the jelly, the bar and the tank's fluid:
  // about 1 300 points.
  const p = await until("points placed", 20_000, (p) => p.pointSets >= 6 && p.points >= 1300);
  assert.ok(p.pointSets >= 6, `${p.pointSets} point sets`);
});

test("the picture shows the demo's objects", async () => {
  await until("frames drawn", 10_000, (p) => p.frames >= 10);
  const { counts } = await canvasPixels();
  assert.ok(counts.sky > counts.total * 0.1, `sky: ${JSON.stringify(counts)}`);
  assert.ok(counts.ground > counts.total * 0.2, `ground: ${JSON.stringify(counts)}`);
  // Bodies cover a good part of the picture, among them the pyramid's
  // blue boxes and the bridge's and crates' wood.
  const bodies = counts.total - counts.sky - counts.ground;
  assert.ok(bodies > counts.total * 0.03, `bodies: ${JSON.stringify(counts)}`);
  for (const body of ["blue", "brown"] as const) {
    assert.ok(counts[body] > 500, `${body} bodies: ${JSON.stringify(counts)}`);
  }
});

test("the picture freezes when the server is paused", async () => {
  admin("pause");
  const paused = await until("the pause", 10_000, (p) => p.paused);
  await new Promise((r) => setTimeout(r, 500));
  const a = await progress();
  const shotA = (await canvasPixels()).digest;
  await new Promise((r) => setTimeout(r, 1000));
  const b = await progress();
  const shotB = (await canvasPixels()).digest;
  assert.ok(b.frames > a.frames, "the page goes on drawing");
  assert.ok(b.snapshots > a.snapshots, "snapshots go on arriving");
  assert.equal(b.tick, a.tick, "the tick moved while paused");
  assert.ok(a.tick >= paused.tick);
  assert.equal(shotA, shotB, "the picture changed while paused");
  admin("resume");
  await until("running again", 10_000, (p) => !p.paused && p.tick > b.tick);
});
