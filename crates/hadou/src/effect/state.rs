//! The world data of the effects a scene uses, by effect name: what an effect's `load` read from
//! the scene file, and what a game changes at run time through `Renderer::update_effect`.

use std::any::Any;
use std::fmt;

/// World data an effect keeps in the scene: any `Clone + Debug` type of its own.
pub trait EffectState: Any + Send + Sync + fmt::Debug {
    /// A boxed copy (scenes are `Clone`).
    fn clone_state(&self) -> Box<dyn EffectState>;
    /// For downcasts to the effect's own type.
    fn as_any(&self) -> &dyn Any;
    /// For downcasts to the effect's own type.
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Any + Send + Sync + fmt::Debug + Clone> EffectState for T {
    fn clone_state(&self) -> Box<dyn EffectState> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// The data of every effect a scene uses, each under its effect's name (`Scene::effects`).
#[derive(Debug, Default)]
pub struct EffectStates {
    entries: Vec<(&'static str, Box<dyn EffectState>)>,
}

impl Clone for EffectStates {
    fn clone(&self) -> Self {
        EffectStates { entries: self.entries.iter().map(|(n, s)| (*n, (**s).clone_state())).collect() }
    }
}

impl EffectStates {
    /// Sets effect `name`'s data (replacing what it had).
    pub fn insert<T: EffectState>(&mut self, name: &'static str, state: T) {
        self.insert_boxed(name, Box::new(state));
    }

    /// Sets effect `name`'s data, boxed (what `Effect::load` returns).
    pub fn insert_boxed(&mut self, name: &'static str, state: Box<dyn EffectState>) {
        self.remove(name);
        self.entries.push((name, state));
    }

    /// Takes effect `name`'s data out (its passes go with it).
    pub fn remove(&mut self, name: &str) -> Option<Box<dyn EffectState>> {
        let i = self.entries.iter().position(|(n, _)| *n == name)?;
        Some(self.entries.remove(i).1)
    }

    /// The first data of type `T` (an effect's own type names it uniquely).
    pub fn get<T: EffectState>(&self) -> Option<&T> {
        self.entries.iter().find_map(|(_, s)| (**s).as_any().downcast_ref::<T>())
    }

    /// The data of type `T`, made by `make` under effect `name` when there is none.
    pub fn get_or_insert_with<T: EffectState>(
        &mut self,
        name: &'static str,
        make: impl FnOnce() -> T,
    ) -> &mut T {
        let i = match self.entries.iter().position(|(_, s)| (**s).as_any().is::<T>()) {
            Some(i) => i,
            None => {
                self.insert(name, make());
                self.entries.len() - 1
            }
        };
        match (*self.entries[i].1).as_any_mut().downcast_mut::<T>() {
            Some(state) => state,
            // The entry was found, or just pushed, as a `T`.
            None => unreachable!("effect state {i} is a {}", std::any::type_name::<T>()),
        }
    }

    /// The data of type `T`, to change (see `Renderer::update_effect`, which also brings the
    /// passes in line).
    pub fn get_mut<T: EffectState>(&mut self) -> Option<&mut T> {
        self.entries.iter_mut().find_map(|(_, s)| (**s).as_any_mut().downcast_mut::<T>())
    }

    /// The name of the effect whose data has type `T`.
    pub fn name_of<T: EffectState>(&self) -> Option<&'static str> {
        self.entries.iter().find(|(_, s)| (**s).as_any().is::<T>()).map(|(n, _)| *n)
    }

    /// A copy of effect `name`'s data (to put back with `insert_boxed`).
    pub fn snapshot(&self, name: &str) -> Option<Box<dyn EffectState>> {
        self.entries.iter().find(|(n, _)| *n == name).map(|(_, s)| (**s).clone_state())
    }

    /// The effect names that hold data, in the order they were inserted.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.entries.iter().map(|(n, _)| *n)
    }

    /// Whether no effect holds data.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Debug, PartialEq)]
    struct Fog(f64);

    #[test]
    fn typed_access_clone_and_replace() {
        let mut states = EffectStates::default();
        states.insert("fog", Fog(1.0));
        states.get_mut::<Fog>().unwrap().0 = 2.0;
        let copy = states.clone();
        states.insert("fog", Fog(3.0));
        assert_eq!(copy.get::<Fog>(), Some(&Fog(2.0)));
        assert_eq!(states.get::<Fog>(), Some(&Fog(3.0)));
        assert_eq!(states.names().collect::<Vec<_>>(), ["fog"]);
        assert!(states.get::<u32>().is_none());
        assert!(states.remove("fog").is_some() && states.is_empty());
    }
}
