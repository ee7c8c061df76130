// The console's words for the server's refusals: the API names a route ("request the control lease
// first (POST /api/lease)"), the console names the button that does it. One table, used wherever a
// server message is shown in the console (console.js `act`, the lease card, scenario.js).

export const BUTTONS = {
  lease: 'Request control', // the rig's control lease (lease.js, the "Control of the rig" card)
  session: 'Take control of this session', // the session's control (the header)
};

const RULES = [
  [/request the control lease first \(POST \/api\/lease\)/i,
    `press “${BUTTONS.lease}” (in “Control of the rig”) first`],
  [/driving the HIP needs the control lease/i, `driving the HIP needs the rig: press “${BUTTONS.lease}” first`],
  [/has no controlling console; take control first/i, `has no controlling console: press “${BUTTONS.session}”`],
  [/take control again/i, `press “${BUTTONS.session}” again`],
  [/abort it through the session \(POST \/api\/sessions\/[^)]*\) before changing the rig/i,
    'abort it in the Run card (Abort) before changing the rig'],
  [/ \((?:GET|POST|PUT|DELETE) \/api\/[^)]*\)/g, ''], // any other route in parentheses: not the console's words
];

/** `text` (a server message, or a sentence around one) in the console's words. */
export function consoleWords(text) {
  let out = String(text ?? '');
  for (const [re, words] of RULES) out = out.replace(re, words);
  return out;
}
