// Starts `hyperslice lsp` for .4ds files.
const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate() {
  const command = vscode.workspace.getConfiguration("hyperslice").get("path", "hyperslice");
  client = new LanguageClient(
    "hyperslice",
    "hyperslice",
    { command, args: ["lsp"] },
    { documentSelector: [{ language: "4ds" }] },
  );
  client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
