// A screenshot of a page in headless Chromium (puppeteer-core, the system's chromium; WebGL
// through SwiftShader, as no GPU is there), after it has run for a while.
// node foxglove_shot.js URL OUT.png WAIT_MS
const puppeteer = require("puppeteer-core");
const [url, out, waitMs] = process.argv.slice(2);
(async () => {
  const browser = await puppeteer.launch({
    executablePath: "/usr/bin/chromium",
    headless: true,
    args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
    defaultViewport: { width: 1600, height: 900 },
  });
  const page = await browser.newPage();
  page.on("pageerror", (e) => console.log("page error:", String(e).slice(0, 300)));
  await page.goto(url, { waitUntil: "load", timeout: 60000 });
  const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
  await sleep(Number(waitMs) / 2);
  // The first-run hint's close buttons, then the layout's Poke button, as a user would.
  const clicked = await page.evaluate(() => {
    const buttons = [...document.querySelectorAll("button")];
    const hints = buttons.filter((b) => b.querySelector('[data-testid="CloseIcon"]'));
    hints.forEach((b) => b.click());
    const poke = buttons.find((b) => b.textContent.trim() === "Poke");
    poke?.click();
    return { hints: hints.length, poke: Boolean(poke) };
  });
  console.log(`closed ${clicked.hints} hints, poked: ${clicked.poke}`);
  await sleep(Number(waitMs) / 2);
  await page.screenshot({ path: out });
  await browser.close();
})().catch((e) => {
  console.error(e);
  process.exit(1);
});
