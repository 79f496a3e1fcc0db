//! A game's hold on the effects' world data at run time (`crate::effect`): read it, change it,
//! add or remove an effect's data; the passes follow on the next frame (a pass the world no
//! longer needs is parked, built; one it needs again is taken back without building).

use super::Renderer;
use crate::effect::{EffectError, EffectState, Effects};
use crate::Error;

impl Renderer {
    /// The effects this renderer runs (`RendererOptions::effects`).
    pub fn effects(&self) -> &Effects {
        &self.effects
    }

    /// The loaded scene's data of type `T` (an effect's own world data type).
    pub fn effect<T: EffectState>(&self) -> Option<&T> {
        self.loaded.as_ref()?.scene.effects.get::<T>()
    }

    /// Changes the loaded scene's data of type `T` for the next frame (e.g. a fog's density);
    /// `EffectError::NoData` when the scene has none (`insert_effect` adds it). A change the
    /// effect's `check` refuses is undone and returned as `Error::InvalidUpdate`.
    pub fn update_effect<T: EffectState>(&mut self, change: impl FnOnce(&mut T)) -> Result<(), Error> {
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let states = &mut loaded.scene.effects;
        let no_data = || EffectError::NoData(std::any::type_name::<T>());
        let name = states.name_of::<T>().ok_or_else(no_data)?;
        let before = states.snapshot(name).ok_or_else(no_data)?;
        change(states.get_mut::<T>().ok_or_else(no_data)?);
        self.checked(name, Some(before))
    }

    /// Gives the registered effect `name` the world data `state` (replacing any), from the next
    /// frame on: how a game brings in an effect its scene file did not have.
    pub fn insert_effect<T: EffectState>(&mut self, name: &str, state: T) -> Result<(), Error> {
        let effect = self.effects.get(name).ok_or_else(|| EffectError::NotRegistered(name.into()))?;
        let name = effect.name();
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let before = loaded.scene.effects.snapshot(name);
        loaded.scene.effects.insert(name, state);
        self.checked(name, before)
    }

    /// Takes effect `name`'s world data out of the scene (its passes are parked); false when the
    /// scene had none.
    pub fn remove_effect(&mut self, name: &str) -> Result<bool, Error> {
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let removed = loaded.scene.effects.remove(name).is_some();
        self.resync_ids();
        self.sync_passes()?;
        Ok(removed)
    }

    /// Asks effect `name` to check its changed data: refused, `before` is put back.
    fn checked(&mut self, name: &'static str, before: Option<Box<dyn EffectState>>) -> Result<(), Error> {
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let verdict = self.effects.get(name).map_or(Ok(()), |e| e.check(&loaded.scene));
        if let Err(expected) = verdict {
            let states = &mut loaded.scene.effects;
            let what = format!("effect {name}: {:?}", states.snapshot(name));
            match before {
                Some(b) => states.insert_boxed(name, b),
                None => drop(states.remove(name)),
            }
            return Err(Error::InvalidUpdate { what, expected });
        }
        self.resync_ids();
        self.sync_passes()
    }

    /// Keeps one id per wave and per metaball group after a change made through the effect API
    /// (their data replaced or removed): ids of objects that remain keep their places, new ones
    /// get new ids.
    fn resync_ids(&mut self) {
        let Some(loaded) = &self.loaded else { return };
        let waves = (loaded.wave_ids.len(), loaded.scene.waves().len());
        let groups = (loaded.group_ids.len(), loaded.scene.metaballs().len());
        let new_waves: Vec<u64> = (waves.0..waves.1).map(|_| self.next_id()).collect();
        let new_groups: Vec<u64> = (groups.0..groups.1).map(|_| self.next_id()).collect();
        if let Some(loaded) = &mut self.loaded {
            loaded.wave_ids.truncate(waves.1);
            loaded.wave_ids.extend(new_waves);
            loaded.group_ids.truncate(groups.1);
            loaded.group_ids.extend(new_groups);
        }
    }
}
