// The Immersive Web Emulation Runtime (npm `iwer`, Meta) for tests, the bench and development
// without a headset: an emulated Meta Quest 3 in hand-tracking mode replaces the browser's
// navigator.xr. Loaded only when the page's URL asks for it (?xr_emulator=quest3); a production
// page never imports it.

export async function installEmulator(kind = 'quest3', { stereo = true } = {}) {
  const iwer = await import('../vendor/iwer/iwer.module.js');
  const configs = { quest3: iwer.metaQuest3, quest2: iwer.metaQuest2, questpro: iwer.metaQuestPro };
  const config = configs[kind];
  if (!config) throw new Error(`unknown emulated headset ${kind} (known: ${Object.keys(configs).join(', ')})`);
  const device = new iwer.XRDevice(config, { stereoEnabled: stereo });
  device.primaryInputMode = 'hand';
  // Headless Chromium has a native navigator.xr whose requestSession needs a user gesture and a
  // headset: replace it.
  device.installRuntime({ forceInstall: true });
  return { device, iwer };
}
