// The audio plan follows the study file (`ask.audio`, protocol v1.5) and the URL flag adds to it.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { AudioPlan, audioSettings, mergedSettings } from '../src/audio.js';

const touching = [{ name: 'right.index.tip', contact: true, lost: false }];

test('without a flag or a study the page is silent', () => {
  const plan = new AudioPlan(audioSettings(null));
  assert.equal(plan.say('Touch the dome'), null);
  assert.equal(plan.clicks(touching), 0);
});

test("the study's audio turns speech and contact sounds on and off", () => {
  const plan = new AudioPlan(audioSettings(''));
  plan.setStudy({ speech: true, contact_sounds: false });
  assert.equal(plan.say('Touch the dome'), 'Touch the dome');
  assert.equal(plan.say('Touch the dome'), null); // once per new text
  assert.equal(plan.clicks(touching), 0);
  plan.clicks([]);
  plan.setStudy({ speech: false, contact_sounds: true }); // the next task's
  assert.equal(plan.say('Rate it'), null);
  assert.equal(plan.clicks(touching), 1);
  plan.setStudy({ speech: false, contact_sounds: false });
  plan.clicks([]);
  assert.equal(plan.clicks(touching), 0);
});

test('the URL flag (demos) adds to the study, never takes away', () => {
  assert.deepEqual(mergedSettings({ speech: true, contact: false }, { speech: false, contact_sounds: true }),
    { speech: true, contact: true });
  assert.deepEqual(mergedSettings({ speech: false, contact: false }, null), { speech: false, contact: false });
  const plan = new AudioPlan(audioSettings('contact'));
  plan.setStudy({ speech: false, contact_sounds: false });
  assert.equal(plan.clicks(touching), 1);
});
