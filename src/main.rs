use hyperslice::{diagnostic, source::SourceMap, syntax};
fn main() {
    let path = std::env::args().nth(1).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut sm = SourceMap::new();
    let id = sm.add(path.clone(), None, text.clone());
    let (ast, diags) = syntax::parse(id, &text);
    print!("{}", syntax::print::print_ast(&ast));
    print!("{}", diagnostic::render_all(&diags, &sm, false));
}
