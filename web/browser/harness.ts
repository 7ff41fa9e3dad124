// What the browser tests share: a real server binary on loopback with the
// page's files, Debian's Chromium driven by playwright-core, and the page's
// progress (`window.inertia`) read and waited on.

import assert from "node:assert/strict";
import { spawn, type ChildProcess } from "node:child_process";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { createInterface } from "node:readline";
import { fileURLToPath } from "node:url";

import { chromium, type Browser, type Page } from "playwright-core";

export const ROOT = fileURLToPath(new URL("../../../", import.meta.url));
const BROWSER = process.env.CHROMIUM_BIN ?? "/usr/bin/chromium";

/** What the page shows of itself (`window.inertia`). */
export interface Progress {
  state: string;
  error: string | null;
  game: string;
  headline: string | null;
  snapshots: number;
  tick: number;
  paused: boolean;
  frames: number;
  entities: number;
  pointSets: number;
  points: number;
  messages: number;
  log: string[];
  matchState: Record<string, number>;
}

/** A server process, the page open on it in a headless browser. */
export interface Session {
  server: ChildProcess;
  dataDir: string;
  /** The server's HTTP address (metrics, /play). */
  http: string;
  browser: Browser;
  page: Page;
}

/** Starts `binary` in dev mode on loopback, serving the page, waits for it
 * to be ready, and opens the page on it. */
export async function open(binary: string): Promise<Session> {
  const dataDir = mkdtempSync(join(tmpdir(), "inertia-browser-"));
  const server = spawn(
    binary,
    [
      "--listen", "127.0.0.1:0",
      "--metrics", "127.0.0.1:0",
      "--data-dir", dataDir,
      "--web-dir", join(ROOT, "web/dist/src"),
      "--log-format", "json",
    ],
    { stdio: ["ignore", "pipe", "inherit"] },
  );
  const http = await new Promise<string>((resolve, reject) => {
    const lines = createInterface({ input: server.stdout! });
    const timer = setTimeout(() => reject(new Error("the server did not get ready in 60 s")), 60_000);
    lines.on("line", (line) => {
      try {
        const fields = JSON.parse(line).fields ?? {};
        if (fields.message === "server ready" && typeof fields.metrics_addr === "string") {
          clearTimeout(timer);
          resolve(fields.metrics_addr);
        }
      } catch {
        // Not a log line of ours.
      }
    });
    server.on("exit", (code) => reject(new Error(`the server exited with ${code}`)));
  });
  const browser = await chromium.launch({
    executablePath: BROWSER,
    headless: true,
    // No GPU here: WebGL2 through SwiftShader.
    args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
  });
  const page = await browser.newPage({ viewport: { width: 960, height: 540 } });
  await page.goto(`http://${http}/play/`);
  return { server, dataDir, http, browser, page };
}

/** Closes the browser, stops the server and removes its data. */
export async function close(s: Session | undefined): Promise<void> {
  await s?.browser.close();
  s?.server.kill("SIGTERM");
  if (s?.dataDir) {
    rmSync(s.dataDir, { recursive: true, force: true });
  }
}

/** The page's progress now. */
export async function progress(page: Page): Promise<Progress> {
  return page.evaluate(() => (window as unknown as { inertia: Progress }).inertia);
}

/** Waits until `done` holds of the page's progress (failing the test after
 * `limitMs`, or at once if the page failed). */
export async function until(
  page: Page,
  what: string,
  limitMs: number,
  done: (p: Progress) => boolean,
): Promise<Progress> {
  const start = Date.now();
  for (;;) {
    const p = await progress(page);
    if (p.state === "failed") {
      assert.fail(`the page failed: ${p.error}`);
    }
    if (done(p)) {
      return p;
    }
    if (Date.now() - start > limitMs) {
      assert.fail(`${what}: not within ${limitMs} ms (${JSON.stringify(p)})`);
    }
    await new Promise((r) => setTimeout(r, 100));
  }
}
